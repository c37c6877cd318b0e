"""A frozen Lo-NeRF's depth and opacity rendered once, as targets: on the
training rays, and on a bank of random rays (from cameras on a hemisphere,
or between the training rays in NDC). Read by the ray-field
stage (L_ray), L_empty and the 3D joint sampler's L_consist."""
import jax
import numpy as np

from halo_jax import camera, models, progress, raycast
from halo_jax.rays import Rays, Targets
from halo_jax.stages.state import StageState


def _targets_fn(lo_state: StageState, num_samples, near, far, white_background, target,
                block_rays):
  lo_model = models.nerf_from_config(lo_state.config, "lo")
  params = lo_state.params["nerf"]

  def fn(o, d, t=None):
    depth, acc = raycast.lo_targets(
        lo_model, params, o, d, num_samples=num_samples, near=near, far=far,
        white_background=white_background, target=target, times=t, block_rays=block_rays)
    return {"depth": depth, "acc": acc}
  return jax.jit(fn)


def on_rays(lo_state: StageState, rays: Rays, *, num_samples, near, far, white_background,
            target="max_weight", chunk=8192, block_rays=0) -> Targets:
  """The frozen Lo-NeRF's depth and opacity [R] on `rays` [R] (numpy)."""
  fn = _targets_fn(lo_state, num_samples, near, far, white_background, target, block_rays)
  with progress.bar(len(rays.origins), "Lo targets", "ray", unit_scale=True) as bar:
    out = raycast.render_chunked(fn, rays.origins, rays.dirs, chunk, rays.times,
                                 on_chunk=bar.update)
  return Targets(rays, out["depth"], out["acc"])


def random_ray_bank(lo_state: StageState, num_rays, radius, focal_over_width, near, far,
                    white_background, num_samples, seed, target="max_weight", chunk=8192,
                    block_rays=0) -> Targets:
  """Random hemisphere rays rendered once by the frozen Lo-NeRF.

  The Lo field is frozen, so its depth and opacity on a fixed bank of random
  rays are exact targets; rendering them once instead of every step is the
  saving (the bank's size is the only approximation). For a dynamic Lo field
  every ray also gets a random time in [0, 1], so the regulariser covers
  times no training view shows.

  Returns Targets on B rays (numpy; times [B, 1] for a dynamic Lo only).
  """
  k_rays, k_time = jax.random.split(jax.random.PRNGKey(seed))
  o, d = camera.random_hemisphere_rays(k_rays, num_rays, radius, focal_over_width)
  times = None
  if models.is_dynamic(lo_state.config, "lo"):
    times = np.asarray(jax.random.uniform(k_time, (num_rays, 1)))
  return on_rays(lo_state, Rays(np.asarray(o), np.asarray(d), times), num_samples=num_samples,
                 near=near, far=far, white_background=white_background, target=target,
                 chunk=chunk, block_rays=block_rays)


def between_ray_bank(lo_state: StageState, num_rays, origins, dirs, near, far,
                     white_background, num_samples, seed, target="max_weight", chunk=8192,
                     block_rays=0) -> Targets:
  """Random rays between the training rays `origins`, `dirs` [R, 3]
  (camera.rays_between: forward-facing scenes) rendered once by the frozen
  Lo-NeRF, as random_ray_bank. Returns Targets on B rays (numpy)."""
  o, d = camera.rays_between(jax.random.PRNGKey(seed), origins, dirs, num_rays)
  return on_rays(lo_state, Rays(np.asarray(o), np.asarray(d)), num_samples=num_samples,
                 near=near, far=far, white_background=white_background, target=target,
                 chunk=chunk, block_rays=block_rays)
