"""Rendering a stage's field along rays: sampling, querying, compositing.

Everything here is a pure function of parameters and rays; `render_chunked`
is the only host-side loop (over fixed-size chunks of an image, padded so one
compiled function serves every chunk).
"""
import functools
from typing import NamedTuple, Optional

import jax
import jax.numpy as jnp
import numpy as np

from halo_jax import camera, models, render, samplers


class Guide(NamedTuple):
  """A frozen ray field that places the samples of a depth-guided NeRF."""
  model: models.RayField
  params: dict
  radius: float


def ray_field_depth(guide: Guide, origins, dirs):
  """Depth along each camera ray predicted by the ray field, and its opacity.

  Args: origins, dirs [..., 3]. Returns depth [...] (camera t), acc [...].
  """
  t_entry, entry, _ = camera.sphere_entry(origins, dirs, guide.radius)
  depth, acc = guide.model.apply({"params": guide.params}, entry, dirs)
  return t_entry + depth, acc


def sample_edges(sampler_cfg, key, shape, near, far, guide_depth=None, randomized=True):
  """Interval edges [*shape, N + 1] for the first (or only) pass of a sampler."""
  n = sampler_cfg.num_samples
  near = jnp.full(shape, near, jnp.float32)
  if sampler_cfg.kind == "depth_guided":
    return samplers.depth_guided(key, guide_depth, near, far, n, sampler_cfg.window,
                                 sampler_cfg.near_only, randomized)
  if sampler_cfg.kind == "hierarchical":
    n = sampler_cfg.num_coarse
  elif sampler_cfg.kind != "stratified":
    raise ValueError(f"sampler.kind={sampler_cfg.kind!r} is not one of "
                     "'stratified', 'hierarchical', 'depth_guided'")
  return samplers.stratified(key, near, far, n, randomized)


def composite(model, params, origins, dirs, t_edges, white_background, key=None, noise=0.0):
  """Queries the NeRF at interval midpoints and composites. Returns render's dict."""
  t_mid = render.interval_midpoints(t_edges)
  pts = origins[..., None, :] + t_mid[..., None] * dirs[..., None, :]
  vdirs = jnp.broadcast_to(dirs[..., None, :], pts.shape)
  sigma, rgb = model.apply({"params": params}, pts, vdirs, key, noise)
  return render.volume_render(sigma, rgb, t_edges, white_background)


def render_rays(model, sampler_cfg, params, origins, dirs, key, *, near, far,
                white_background, randomized, noise=0.0, guide: Optional[Guide] = None):
  """Renders rays with a NeRF stage's sampler.

  Args:
    model: NeRFMLP; sampler_cfg: the stage's `sampler` config.
    params: model parameters.
    origins, dirs: [R, 3] rays (dirs unit length).
    key: PRNG key for jitter and density noise.
    near, far: scalar bounds.
    randomized: jitter samples (training) or not (evaluation).
    noise: density noise std (training only).
    guide: ray field for sampler_cfg.kind == 'depth_guided'.

  Returns:
    list of render dicts, coarse first; the last is the final rendering.
  """
  k_s, k_n, k_f, k_n2 = jax.random.split(key, 4)
  shape = origins.shape[:-1]
  guide_depth = None
  if sampler_cfg.kind == "depth_guided":
    guide_depth, _ = ray_field_depth(guide, origins, dirs)
    guide_depth = jax.lax.stop_gradient(guide_depth)
  t = sample_edges(sampler_cfg, k_s, shape, near, far, guide_depth, randomized)
  out = [composite(model, params, origins, dirs, t, white_background, k_n, noise)]
  if sampler_cfg.kind == "hierarchical":
    t_fine = samplers.hierarchical(k_f, t, out[0]["weights"], sampler_cfg.num_samples,
                                   randomized)
    out.append(composite(model, params, origins, dirs, t_fine, white_background, k_n2, noise))
  return out


def render_chunked(fn, origins, dirs, chunk: int):
  """Applies a jitted `fn(origins [C, 3], dirs [C, 3]) -> dict of [C, ...]` to any
  number of rays in fixed-size chunks; returns numpy arrays [R, ...]."""
  flat_o, flat_d = origins.reshape(-1, 3), dirs.reshape(-1, 3)
  n = flat_o.shape[0]
  pad = (-n) % chunk
  flat_o = np.concatenate([flat_o, np.repeat(flat_o[-1:], pad, 0)])
  flat_d = np.concatenate([flat_d, np.repeat(flat_d[-1:], pad, 0)])
  outs = []
  for i in range(0, n + pad, chunk):
    outs.append(jax.device_get(fn(flat_o[i:i + chunk], flat_d[i:i + chunk])))
  merged = {k: np.concatenate([o[k] for o in outs])[:n] for k in outs[0]}
  return {k: v.reshape(origins.shape[:-1] + v.shape[1:]) for k, v in merged.items()}


def make_eval_fn(model, sampler_cfg, *, near, far, white_background, guide_model=None,
                 radius=None):
  """A jitted (params, guide_params, origins, dirs) -> {rgb, depth, depth_max, acc}
  for held-out rendering; compiled once and reused for every evaluation."""
  @jax.jit
  def fn(params, guide_params, o, d):
    guide = Guide(guide_model, guide_params, radius) if guide_model is not None else None
    out = render_rays(model, sampler_cfg, params, o, d, jax.random.PRNGKey(0), near=near,
                      far=far, white_background=white_background, randomized=False,
                      guide=guide)[-1]
    return {"rgb": out["rgb"], "depth": render.normalized_depth(out["depth"], out["acc"]),
            "depth_max": out["depth_max"], "acc": out["acc"]}
  return fn


@functools.partial(jax.jit, static_argnames=("model", "num_samples", "near", "far",
                                             "white_background", "target"))
def lo_targets(model, params, origins, dirs, *, num_samples, near, far, white_background,
               target="max_weight"):
  """Frozen-field depth and opacity on rays, for L_ray and L_empty.

  Returns depth [R] (the max-weight sample, or the normalised expected depth)
  and acc [R].
  """
  t = samplers.stratified(None, jnp.full(origins.shape[:-1], near), far, num_samples,
                          randomized=False)
  out = composite(model, params, origins, dirs, t, white_background)
  depth = out["depth_max"] if target == "max_weight" else render.normalized_depth(
      out["depth"], out["acc"])
  return depth, out["acc"]
