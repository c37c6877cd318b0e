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
    """Interval edges [N + 1] of one ray (scalar near, far, guide_depth; one
    PRNG key) for the first (or only) pass. window: a guided sampler's half
    window as a fraction of far - near (may be traced; None: sampler_cfg's);
    num_full: of a guided sampler's intervals, this many stratified over all
    of [near, far], the rest (less the one the union adds) in the window."""
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
  """N intervals of equal length in [near, far] ([...] or scalars), each
  interior edge jittered uniformly by up to half an interval when randomized
  (NeRF's stratified sampling). key: a PRNG key or per-ray keys [R, 2]
  (halo_jax.rng). Returns sorted t_edges [..., N + 1] from near to far."""
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
  """The interval (lo, hi), each [...], that the depth-guided sampler fills
  around depth d [...], DONeRF-style: [max(near, d - r (far - near)),
  min(far, d + r (far - near))], r = radius. `near_only` keeps far as the
  upper bound (the authors' variant). A depth outside [near, far] is clipped
  into it first; a NaN depth gives the whole [near, far]."""
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
  """Window edges [..., N + 1] plus `num_full` stratified intervals over all
  of [near, far] (key: theirs): the sorted union, t_edges [..., N + num_full
  + 1], tiles [near, far] densely inside the window and coarsely outside it,
  so the field can still put density anywhere on the ray (the authors'
  light-field sampler draws half its samples so). num_full 0: unchanged."""
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
  """Inverse-CDF resampling of the piecewise-constant distribution of coarse
  weights [..., M] (need not sum to 1) over t_edges [..., M + 1] (NeRF):
  sorted t_edges [..., N + 1] inside the coarse range, N = num_samples, from
  uniform u (randomized) or evenly spaced u. eps: a weight floor, so a ray
  with all-zero weights falls back to uniform."""
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

  Half-width w / 2 of the range around the guide [...] (the ray field's
  depth), clipped to it, then blended towards the range ends by 1 - w:
  (lo, hi) = (w lo' + (1 - w) near, w hi' + (1 - w) far), w = width in (0, 1]
  (may be traced). Away from the ends its length is (1 - w + w^2) of the
  range: all of it at w = 1 and at w = 0, 75% at w = 0.5, 91% at w = 0.1. It
  never narrows to w of the range; it shifts towards the guide.
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

  K = num_full points evenly over [near, far] (ends included) and M points
  in blended_window (one ray: scalars) placed by u_window [M] in [0, 1),
  sorted; when randomized each point moves within the half-gaps to its
  neighbours by u_jitter [K + M] (their perturb). The points are the left
  edges of their intervals, the last as long as the one before it (their
  `dist`): sorted t_edges [K + M + 1].
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
