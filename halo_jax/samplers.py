"""Where to put samples along a ray: stratified, hierarchical, depth-guided.

Every sampler is written for one ray, with one PRNG key, and returns its
sorted interval edges `t_edges` [N + 1]; `raycast` maps them over a batch of
rays with `jax.vmap` (each ray its own key), queries the field at the
midpoints and composites the N intervals with `render.volume_render`. (They
also accept leading batch axes, [..., N + 1], for host-side callers.)
"""
import dataclasses
import functools
from typing import Callable, Optional

import jax
import jax.numpy as jnp

from halo_jax import geometry, registry, rng


@dataclasses.dataclass(frozen=True)
class SamplerSpec:
  """What a sampler kind (config `sampler.kind`) does and needs.

  Attributes:
    guided: samples fill a window around a ray field's depth.
    importance: a second pass resamples the first pass's weights (inverse CDF).
    merge_coarse: the second pass composites its samples together with the
      first pass's (the original NeRF), not alone.
    needs: stages whose finished states the sampler reads (a frozen ray
      field; Lo-NeRF targets for a ray field trained alongside).
    trains_guide: the ray field that guides it trains in the same stage.
    geometries: the ray geometries it supports.
    dynamic: whether it works on a time-dependent field.
    guided_edges: a guided sampler's own edges (key, guide_depth, near, far,
      window, num_samples, num_full, randomized) -> [N + 1]; None: stratified
      in depth_window, with_full_range's full-range samples.
  """
  guided: bool = False
  importance: bool = False
  merge_coarse: bool = False
  needs: tuple = ()
  trains_guide: bool = False
  geometries: frozenset = geometry.ALL
  dynamic: bool = True
  guided_edges: Optional[Callable] = None

  def edges(self, sampler_cfg, key, near, far, *, guide_depth=None, window=None,
            num_full: int = 0, randomized: bool = True):
    """Interval edges [N + 1] of one ray for the first (or only) pass.

    Args:
      sampler_cfg: the stage's `sampler` config (num_samples, num_coarse,
        window, near_only).
      key: one PRNG key (unused when randomized is False).
      near, far: the ray's bounds (scalars).
      guide_depth: a guided sampler's guide depth on this ray (scalar).
      window: a guided sampler's half window, a fraction of far - near (may
        be traced); None for sampler_cfg.window.
      num_full: guided samplers: of the num_samples intervals, this many
        stratified over all of [near, far] and the rest (less the one
        interval the union adds) in the window (with_full_range).
      randomized: jitter the samples.
    """
    n = sampler_cfg.num_coarse if self.importance else sampler_cfg.num_samples
    if not self.guided:
      return stratified(key, near, far, n, randomized)
    window = sampler_cfg.window if window is None else window
    if self.guided_edges is not None:
      return self.guided_edges(key, guide_depth, near, far, window, n, num_full, randomized)
    n_win, k_full = n, None
    if num_full > 0:
      n_win -= num_full + 1
      if n_win < 1:
        raise ValueError(f"{num_full} full-range samples leave no window samples of the "
                         f"{n} a ray has (sampler.num_full, joint.full_range)")
      key, k_full = jax.random.split(key)
    edges = depth_guided(key, guide_depth, near, far, n_win, window, sampler_cfg.near_only,
                         randomized)
    return with_full_range(k_full, edges, near, far, num_full, randomized)


SAMPLERS = registry.Registry[SamplerSpec]("sampler")
SAMPLERS.register("stratified", SamplerSpec())
SAMPLERS.register("hierarchical", SamplerSpec(importance=True, geometries=geometry.SPATIAL))
# NeRF's coarse + fine: the fine pass composites coarse and fine samples together.
SAMPLERS.register("coarse_fine", SamplerSpec(importance=True, merge_coarse=True,
                                             geometries=geometry.SPATIAL))
SAMPLERS.register("depth_guided", SamplerSpec(guided=True, needs=("ray",),
                                              geometries=geometry.SPATIAL, dynamic=False))
# The window's num_coarse samples, then num_samples drawn from their weights,
# composited together (NeRF's coarse + fine inside the ray field's window).
SAMPLERS.register("depth_guided_fine", SamplerSpec(
    guided=True, importance=True, merge_coarse=True, needs=("ray",),
    geometries=geometry.SPATIAL, dynamic=False))
# A ray field trained with the stage: in 3D it follows Lo-NeRF's depth; on a
# light field, the radiance field's own.
SAMPLERS.register("joint", SamplerSpec(guided=True, trains_guide=True, dynamic=False))


def stratified(key, near, far, num_samples: int, randomized: bool = True):
  """N intervals of equal length in [near, far], jittered as one when training.

  Edges are jittered by one shared uniform offset per interval edge (NeRF's
  stratified sampling); the first and last edge stay at near and far.

  Args:
    key: PRNG key, or per-ray keys [R, 2] (see halo_jax.rng); unused when
      randomized is False.
    near, far: [...] bounds per ray (or scalars broadcast to the batch).
    num_samples: N.
    randomized: jitter the interior edges.

  Returns:
    t_edges [..., N + 1], sorted, with t_edges[..., 0] = near, [..., -1] = far.
  """
  near = jnp.asarray(near, jnp.float32)
  far = jnp.asarray(far, jnp.float32)
  shape = jnp.broadcast_shapes(near.shape, far.shape)
  u = jnp.linspace(0.0, 1.0, num_samples + 1)
  u = jnp.broadcast_to(u, shape + (num_samples + 1,))
  if randomized:
    jitter = rng.uniform(key, shape + (num_samples - 1,), minval=-0.5, maxval=0.5)
    interior = u[..., 1:-1] + jitter / num_samples
    u = jnp.concatenate([u[..., :1], interior, u[..., -1:]], axis=-1)
  return near[..., None] + (far - near)[..., None] * u


def depth_window(depth, near, far, radius: float, near_only: bool = False):
  """The interval the depth-guided sampler fills, DONeRF-style.

  [max(near, d - r (far - near)), min(far, d + r (far - near))]. `near_only`
  keeps far as the upper bound (the authors' variant). A depth outside
  [near, far] is clipped into it first; a NaN depth gives the whole [near, far].

  Args:
    depth: [...] predicted depth.
    near, far: scalars or [...].
    radius: r, as a fraction of far - near.
    near_only: tighten only the near side.

  Returns:
    (lo, hi), each [...].
  """
  near = jnp.asarray(near, jnp.float32)
  far = jnp.asarray(far, jnp.float32)
  finite = jnp.isfinite(depth)
  d = jnp.clip(jnp.where(finite, depth, near), near, far)
  half = radius * (far - near)
  lo = jnp.where(finite, jnp.maximum(near, d - half), near)
  hi = far if near_only else jnp.where(finite, jnp.minimum(far, d + half), far)
  lo, hi = jnp.broadcast_arrays(lo, hi)
  return lo, hi


def window_at(sampler_cfg, step):
  """A guided sampler's half window at training `step`: `window_start`
  falling linearly to `window` over `window_steps` steps; None where the
  window is constant (window_steps 0), so the sampler reads `window` itself.

  step may be traced; returns a float32 scalar (or None)."""
  steps = sampler_cfg.get("window_steps", 0)
  if steps <= 0:
    return None
  frac = jnp.clip(jnp.asarray(step, jnp.float32) / steps, 0.0, 1.0)
  start = sampler_cfg.window_start
  return jnp.float32(start) + (sampler_cfg.window - start) * frac


def depth_guided(key, depth, near, far, num_samples: int, radius: float,
                 near_only: bool = False, randomized: bool = True):
  """Stratified samples inside `depth_window`; returns t_edges [..., N + 1]."""
  lo, hi = depth_window(depth, near, far, radius, near_only)
  return stratified(key, lo, hi, num_samples, randomized)


def with_full_range(key, window_edges, near, far, num_full: int, randomized: bool = True):
  """Window samples plus `num_full` stratified intervals over all of [near, far].

  The union of both sets of edges, sorted: N + num_full + 1 intervals that
  tile [near, far], dense inside the window and coarse outside it, so the
  field can still put density anywhere on the ray (the authors' light-field
  sampler draws half its samples so).

  Args:
    key: PRNG key for the full-range samples (per-ray keys [R, 2] allowed).
    window_edges: [..., N + 1] sorted edges inside [near, far].
    near, far: [...] bounds (or scalars).
    num_full: intervals over the whole range (0: window_edges unchanged).

  Returns:
    t_edges [..., N + num_full + 1], sorted, from near to far.
  """
  if num_full <= 0:
    return window_edges
  full = stratified(key, jnp.broadcast_to(jnp.asarray(near, jnp.float32),
                                          window_edges.shape[:-1]),
                    far, num_full, randomized)
  return jnp.sort(jnp.concatenate([full, window_edges], -1), axis=-1)


def merge_edges(a, b):
  """The union of two sorted edge sets over the same range: [..., Na + Nb]
  sorted edges (NeRF's fine pass over its coarse and fine samples)."""
  return jnp.sort(jnp.concatenate([a, b], -1), axis=-1)


def hierarchical(key, t_edges, weights, num_samples: int, randomized: bool = True,
                 eps: float = 1e-5):
  """Inverse-CDF resampling of a piecewise-constant weight distribution (NeRF).

  Args:
    key: PRNG key.
    t_edges: [..., M + 1] edges of the coarse intervals.
    weights: [..., M] coarse weights (need not sum to 1).
    num_samples: N, new intervals.
    randomized: uniform u instead of evenly spaced u.
    eps: weight floor so a ray with all-zero weights falls back to uniform.

  Returns:
    t_edges [..., N + 1] drawn from the distribution, sorted, inside the
    coarse range.
  """
  weights = jax.lax.stop_gradient(weights) + eps
  pdf = weights / weights.sum(-1, keepdims=True)
  cdf = jnp.concatenate([jnp.zeros_like(pdf[..., :1]),
                         jnp.minimum(1.0, jnp.cumsum(pdf, -1))], -1)
  cdf = cdf.at[..., -1].set(1.0)
  shape = weights.shape[:-1] + (num_samples + 1,)
  if randomized:
    u = jnp.sort(rng.uniform(key, shape), axis=-1)
  else:
    u = jnp.broadcast_to(jnp.linspace(0.0, 1.0, num_samples + 1), shape)
  interp = jnp.vectorize(jnp.interp, signature="(n),(m),(m)->(n)")
  t = interp(u, cdf, jax.lax.stop_gradient(t_edges))
  return jnp.sort(t, axis=-1)


def blended_window(guide, near, far, width):
  """The authors' light-field sampling window (their update_sample_near_far).

  Half-width width / 2 of the range around the guide, clipped to it, then
  blended towards the range ends by 1 - width: [w lo' + (1 - w) near,
  w hi' + (1 - w) far]. Away from the ends its length is (1 - w + w^2) of
  the range: all of it at w = 1 and at w = 0, 75% at w = 0.5, 91% at
  w = 0.1. It never narrows to w of the range; it shifts towards the guide.

  Args:
    guide: [...] the ray field's depth.
    near, far: the range (scalars or [...]).
    width: w in (0, 1], the window's width as a share of the range (may be traced).

  Returns:
    (lo, hi), each [...].
  """
  near = jnp.asarray(near, jnp.float32)
  far = jnp.asarray(far, jnp.float32)
  half = 0.5 * width * (far - near)
  lo = width * jnp.maximum(guide - half, near) + (1.0 - width) * near
  hi = width * jnp.minimum(guide + half, far) + (1.0 - width) * far
  return lo, hi


def blended_edges_of(u_window, u_jitter, guide, near, far, width, num_full: int,
                     randomized: bool = True):
  """The authors' light-field samples as interval edges, from given uniforms.

  `num_full` points evenly over [near, far] (ends included) and
  len(u_window) points uniform in blended_window, sorted; when randomized
  each point is moved uniformly within the half-gaps to its neighbours
  (their perturb); the points are the left edges of their intervals, the
  last interval as long as the one before it (their `dist`).

  Args:
    u_window: [M] uniforms in [0, 1) placing the window's points.
    u_jitter: [num_full + M] uniforms for the perturbation.
    guide, near, far, width: as blended_window (scalars: one ray).
    num_full: K evenly spaced points.

  Returns:
    t_edges [K + M + 1], sorted.
  """
  lo, hi = blended_window(guide, near, far, width)
  points = jnp.sort(jnp.concatenate([jnp.linspace(near, far, num_full),
                                     lo + (hi - lo) * u_window]))
  if randomized:
    mids = 0.5 * (points[1:] + points[:-1])
    upper = jnp.concatenate([mids, points[-1:]])
    lower = jnp.concatenate([points[:1], mids])
    points = lower + (upper - lower) * u_jitter
  return jnp.concatenate([points, points[-1:] + (points[-1] - points[-2])])


def blended_edges(key, guide_depth, near, far, window, num_samples: int, num_full: int,
                  randomized: bool = True, even: bool = False):
  """blended_edges_of with its uniforms drawn from `key` (one ray): N =
  num_samples intervals, num_full of their points evenly spaced, the rest in
  the window (window: its width share, lightfield.alpha_schedule's value),
  drawn uniformly there or, with `even`, evenly spaced (then jittered)."""
  k_win, k_jit = jax.random.split(key)
  num_window = num_samples - num_full
  if randomized and not even:
    u_window = rng.uniform(k_win, (num_window,))
  elif even:  # their LLFF sampler: evenly over the window, ends included
    u_window = jnp.linspace(0.0, 1.0, num_window)
  else:  # evaluation: the window's points evenly spread, not drawn
    u_window = (jnp.arange(num_window) + 0.5) / num_window
  u_jitter = rng.uniform(k_jit, (num_samples,))
  return blended_edges_of(u_window, u_jitter, guide_depth, near, far, window, num_full,
                          randomized)


# The authors' light-field sampler: samples half evenly over the range, half
# uniform in a window blended towards the range ends, around the depth of a
# ray field trained with the stage.
SAMPLERS.register("joint_blended", SamplerSpec(
    guided=True, trains_guide=True, dynamic=False, guided_edges=blended_edges,
    geometries=frozenset({geometry.Geometry.TWO_PLANE})))
# Their LLFF light field's: every sample evenly over the blended window.
SAMPLERS.register("joint_blended_even", SamplerSpec(
    guided=True, trains_guide=True, dynamic=False,
    guided_edges=functools.partial(blended_edges, even=True),
    geometries=frozenset({geometry.Geometry.TWO_PLANE})))
