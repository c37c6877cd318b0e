"""Rendering a radiance field along rays: sampling, querying, compositing.

Everything here is a pure function of parameters and rays; `render_chunked`
is the only host-side loop (over fixed-size chunks of an image, padded so one
compiled function serves every chunk). Models are passed in (any Flax module
with the radiance-field call signature), never imported.
"""
import functools
from typing import Any, NamedTuple, Optional

import jax
import jax.numpy as jnp
import numpy as np

from halo_jax import camera, render, rng, samplers
from halo_jax.geometry import Geometry
from halo_jax.rays import Rays
from halo_jax.types import Params


class Guide(NamedTuple):
  """A ray field that places the samples of a guided sampler.

  geometry: how rays enter the field: SPHERE where they cross the sphere of
  `radius`; NDC as they are (they start on the near plane).
  """
  model: Any              # the Flax ray field
  params: Params
  geometry: Geometry
  radius: float = 0.0


def ray_field_depth(guide: Guide, origins, dirs):
  """Depth along each camera ray predicted by the ray field, and its opacity.

  Args: origins, dirs [..., 3]. Returns depth [...] (camera t), acc [...].
  """
  if guide.geometry == Geometry.NDC:
    return guide.model.apply({"params": guide.params}, origins, dirs)
  if guide.geometry != Geometry.SPHERE:
    raise ValueError(f"a 3D ray field cannot read {guide.geometry.value} rays")
  t_entry, entry, _ = camera.sphere_entry(origins, dirs, guide.radius)
  depth, acc = guide.model.apply({"params": guide.params}, entry, dirs)
  return t_entry + depth, acc


def ray_points(origin, direction, t_edges):
  """The midpoints of one ray's intervals: origin, direction [3], t_edges
  [N + 1] -> points [N, 3] and their view directions [N, 3]."""
  t_mid = render.interval_midpoints(t_edges)
  points = origin + t_mid[:, None] * direction
  return points, jnp.broadcast_to(direction, points.shape)


def composite(model, params, origins, dirs, t_edges, white_background, key=None, noise=0.0,
              times=None, band_fraction=None, points_of=ray_points):
  """Queries the field at every ray's interval midpoints and composites each
  ray. Returns render.volume_render's dict [R, ...] plus 'sigma' [R, N].

  origins, dirs [R, D]; t_edges [R, N + 1]. The field runs once on all R x N
  points (its layers on rows are its fast form); placing the points and
  compositing are written for one ray and mapped over the rays.
  key: per-ray keys [R, 2] for density noise, or None.
  times: [R, 1] per-ray time for a dynamic field (None for a static one).
  band_fraction: FreeNeRF's P.E. mask position (models.band_weights), or None.
  points_of: (origin, dir, t_edges) of one ray -> (points [N, P], the
    field's view input [N, V]): ray_points for 3D rays,
    lightfield.ray_points for two-plane ones.
  """
  pts, vdirs = jax.vmap(points_of)(origins, dirs, t_edges)
  extra = {} if band_fraction is None else {"band_fraction": band_fraction}
  if times is not None:
    extra["times"] = times[..., None, :]
  sigma, rgb = model.apply({"params": params}, pts, vdirs, key, noise, **extra)
  out = jax.vmap(render.volume_render, in_axes=(0, 0, 0, None))(sigma, rgb, t_edges,
                                                                  white_background)
  out["sigma"] = sigma
  return out


def per_ray_keys(key, num_rays: int, randomized: bool, noise: float):
  """Per-ray keys [R, 2]: `key` itself when it is per ray; else one key for a
  batch that draws nothing (no jitter, no density noise), repeated."""
  if rng.is_per_ray(key):
    return key
  if randomized or noise:
    raise ValueError("one PRNG key for a batch that draws would give every ray the same "
                     "numbers: pass per-ray keys [R, 2]")
  return jnp.broadcast_to(key, (num_rays, *key.shape))


def render_rays(model, sampler_cfg, params, origins, dirs, key, *, near, far,
                white_background, randomized, noise=0.0, guide: Optional[Guide] = None,
                times=None, window=None, coarse_params=None, band_fraction=None):
  """Renders rays origins, dirs [R, 3] (unit dirs) between scalar near and
  far with a NeRF stage's sampler (sampler_cfg, its `sampler` section): each
  ray's samples drawn from its own key (per-ray keys [R, 2], or one key when
  nothing is drawn) by the per-ray samplers (SamplerSpec.edges,
  samplers.hierarchical), mapped over the rays here. Returns the render
  dicts, coarse first; the last is the final rendering.

  coarse_params: a second field's parameters for an importance sampler's
  first pass (NeRF's coarse MLP; None: `params` serve both). randomized:
  jitter (training) or not (evaluation); noise: density noise std. guide:
  the guided samplers' ray field; window: their half window (None:
  sampler_cfg.window), sampler_cfg.num_full of their samples spanning all
  of [near, far]. times [R, 1]: a dynamic field's; band_fraction: FreeNeRF's
  mask position (models.band_weights) or None.
  """
  spec = samplers.SAMPLERS.get(sampler_cfg.kind, "sampler.kind")
  keys = per_ray_keys(key, origins.shape[0], randomized, noise)
  k_s, k_n, k_f, k_n2 = rng.split(keys, 4)
  guide_depth = None
  if spec.guided:
    guide_depth, _ = ray_field_depth(guide, origins, dirs)
    guide_depth = jax.lax.stop_gradient(guide_depth)
  edges = functools.partial(spec.edges, sampler_cfg, near=near, far=far, randomized=randomized,
                            window=window, num_full=sampler_cfg.get("num_full", 0))
  t = jax.vmap(lambda k, g: edges(k, guide_depth=g))(k_s, guide_depth)
  first = params if coarse_params is None else coarse_params
  out = [composite(model, first, origins, dirs, t, white_background, k_n, noise, times,
                   band_fraction)]
  if spec.importance:
    resample = functools.partial(samplers.hierarchical, num_samples=sampler_cfg.num_samples,
                                 randomized=randomized)
    t_fine = jax.vmap(resample)(k_f, t, out[0]["weights"])
    if spec.merge_coarse:
      t_fine = jax.vmap(samplers.merge_edges)(jax.lax.stop_gradient(t), t_fine)
    out.append(composite(model, params, origins, dirs, t_fine, white_background, k_n2, noise,
                         times, band_fraction))
  return out


def render_chunked(fn, origins, dirs, chunk: int, times=None, on_chunk=None):
  """Applies a jitted `fn(origins [C, 3], dirs [C, 3][, times [C, 1]]) -> dict of
  [C, ...]` to any number of rays in fixed-size chunks; returns numpy arrays
  [R, ...]. `times` [..., 1] (dynamic scenes) is passed when given;
  `on_chunk(rays)` is called after each chunk with the rays it rendered."""
  inputs = [np.asarray(origins).reshape(-1, 3), np.asarray(dirs).reshape(-1, 3)]
  if times is not None:
    inputs.append(np.asarray(times, np.float32).reshape(-1, 1))
  n = inputs[0].shape[0]
  pad = (-n) % chunk
  inputs = [np.concatenate([x, np.repeat(x[-1:], pad, 0)]) for x in inputs]
  outs = []
  for i in range(0, n + pad, chunk):
    outs.append(jax.device_get(fn(*(x[i:i + chunk] for x in inputs))))
    if on_chunk is not None:
      on_chunk(min(chunk, n - i))
  merged = {k: np.concatenate([o[k] for o in outs])[:n] for k in outs[0]}
  return {k: v.reshape(origins.shape[:-1] + v.shape[1:]) for k, v in merged.items()}


def in_blocks(fn, block_rays: int, *rays):
  """fn(*rays) computed over consecutive blocks of `block_rays` rays, one after
  another (lax.map): on CPU a block's activations stay in cache, which is
  several times faster than one pass over a large chunk. Each x in `rays` is
  [R, ...] (None passes through; R is padded up to whole blocks by repeating
  the last ray); fn returns a pytree of [block, ...]. block_rays 0 runs fn
  once on everything.
  """
  n = rays[0].shape[0]
  if not block_rays or block_rays >= n:
    return fn(*rays)
  present = [i for i, x in enumerate(rays) if x is not None]
  num = -(-n // block_rays)
  pad = num * block_rays - n

  def blocks_of(x):
    x = jnp.concatenate([x, jnp.repeat(x[-1:], pad, 0)]) if pad else x
    return x.reshape(num, block_rays, *x.shape[1:])

  def one(blocks):
    args = list(rays)
    for i, x in zip(present, blocks):
      args[i] = x
    return fn(*args)
  out = jax.lax.map(one, tuple(blocks_of(rays[i]) for i in present))
  return jax.tree_util.tree_map(lambda y: y.reshape(num * block_rays, *y.shape[2:])[:n], out)


def jit_eval(render_final, block_rays: int = 0):
  """A jitted (state, origins, dirs[, times]) -> eval_outputs for held-out
  rendering, compiled once per state structure and reused.

  render_final: (state, rays.Rays) -> the final render dict; state is
  whatever pytree it reads (parameters, a window). block_rays: see in_blocks
  (config eval.block_rays).
  """
  @jax.jit
  def fn(state, o, d, times=None):
    def render_block(o, d, times):
      return eval_outputs(render_final(state, Rays(o, d, times)))
    return in_blocks(render_block, block_rays, o, d, times)
  return fn


def make_eval_fn(model, sampler_cfg, *, near, far, white_background, guide_model=None,
                 geometry=Geometry.SPHERE, radius=0.0, block_rays: int = 0):
  """(params, guide_params, origins, dirs[, times, window, coarse_params,
  band_fraction]) -> {rgb, depth, depth_max, acc}: held-out rendering of a
  3D radiance field with its sampler (jit_eval)."""
  def render_final(state, rays):
    params, guide_params, window, coarse_params, band_fraction = state
    guide = None if guide_model is None else Guide(guide_model, guide_params, geometry, radius)
    return render_rays(model, sampler_cfg, params, rays.origins, rays.dirs,
                       jax.random.PRNGKey(0), near=near, far=far,
                       white_background=white_background, randomized=False, guide=guide,
                       times=rays.times, window=window, coarse_params=coarse_params,
                       band_fraction=band_fraction)[-1]
  jitted = jit_eval(render_final, block_rays)

  def fn(params, guide_params, o, d, times=None, window=None, coarse_params=None,
         band_fraction=None):
    return jitted((params, guide_params, window, coarse_params, band_fraction), o, d, times)
  return fn


def eval_outputs(out):
  """What a held-out render keeps of a render dict: rgb [R, 3], depth (the
  normalised expected depth) [R], depth_max [R], acc [R]."""
  return {"rgb": out["rgb"], "depth": render.normalized_depth(out["depth"], out["acc"]),
          "depth_max": out["depth_max"], "acc": out["acc"]}


DEPTH_TARGETS = ("max_weight", "max_weight_open_end", "expected")


@functools.partial(jax.jit, static_argnames=("model", "num_samples", "near", "far",
                                             "white_background", "target", "block_rays"))
def lo_targets(model, params, origins, dirs, *, num_samples, near, far, white_background,
               target="max_weight", times=None, block_rays=0):
  """Frozen-field depth and opacity on rays (at `times` [R, 1] for a dynamic
  field), for L_ray and L_empty. block_rays: see in_blocks.

  Returns depth [R] (target: 'max_weight', the largest weight's sample;
  'max_weight_open_end', the same with the last interval open to the
  authors' 2e10 (render.open_end_max_depth); 'expected', the normalised
  expected depth) and acc [R].
  """
  def targets(origins, dirs, times):
    t = jax.vmap(lambda o: samplers.stratified(None, near, far, num_samples,
                                               randomized=False))(origins)
    out = composite(model, params, origins, dirs, t, white_background, times=times)
    if target == "expected":
      depth = render.normalized_depth(out["depth"], out["acc"])
    elif target == "max_weight_open_end":
      depth = jax.vmap(render.open_end_max_depth)(out["weights"], out["sigma"], t)
    else:
      depth = out["depth_max"]
    return depth, out["acc"]
  return in_blocks(targets, block_rays, origins, dirs, times)
