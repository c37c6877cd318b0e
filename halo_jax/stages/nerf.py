"""Lo-NeRF and Hi-NeRF (and the vanilla-NeRF baseline): one NeRF stage, configured.

Lo-NeRF: low-frequency P.E., no view directions, stratified samples.
Hi-NeRF: high-frequency P.E., samples placed by the frozen ray field, plus
L_empty against the frozen Lo-NeRF on random rays.
Vanilla NeRF: the Hi stage with stratified samples and no L_empty.
"""
import functools
import os
import time

import jax
import jax.numpy as jnp
import numpy as np

from halo_jax import camera, evaluate, losses, metrics, models, parallel, samplers
from halo_jax.stages import field, loop
from halo_jax.stages.state import StageState, stage_dir


def init_params(model, seed):
  pts = jnp.zeros((1, 3))
  return model.init(jax.random.PRNGKey(seed), pts, pts)["params"]


def training_rays(views, precrop_frac):
  """All training pixels as flat rays, plus the indices inside the centre crop.

  Returns dict of numpy arrays: origins, dirs, rgb [R, 3], crop_idx [Rc].
  """
  o, d = views.rays()
  n, h, w = views.images.shape[:3]
  dh, dw = int(h * precrop_frac / 2), int(w * precrop_frac / 2)
  mask = np.zeros((n, h, w), bool)
  mask[:, h // 2 - dh:h // 2 + dh, w // 2 - dw:w // 2 + dw] = True
  return {"origins": o.reshape(-1, 3), "dirs": d.reshape(-1, 3),
          "rgb": views.images.reshape(-1, 3),
          "crop_idx": np.flatnonzero(mask.reshape(-1)).astype(np.int32)}


def random_ray_bank(lo_state: StageState, num_rays, radius, focal_over_width, near, far,
                    white_background, num_samples, seed, target="max_weight", chunk=8192):
  """Random hemisphere rays rendered once by the frozen Lo-NeRF.

  The Lo field is frozen, so its depth and opacity on a fixed bank of random
  rays are exact targets; rendering them once instead of every step is the
  saving (the bank's size is the only approximation).

  Returns dict: origins, dirs [B, 3], depth, acc [B] (numpy).
  """
  lo_model = models.nerf_from_config(lo_state.config, "lo")
  o, d = camera.random_hemisphere_rays(jax.random.PRNGKey(seed), num_rays, radius,
                                       focal_over_width)
  fn = lambda oo, dd: dict(zip(("depth", "acc"), field.lo_targets(
      lo_model, lo_state.params, oo, dd, num_samples=num_samples, near=near, far=far,
      white_background=white_background, target=target)))
  out = field.render_chunked(jax.jit(fn), np.asarray(o), np.asarray(d), chunk)
  return {"origins": np.asarray(o), "dirs": np.asarray(d), **out}


def transfer_from_lo(hi_params, lo_params, lo_inputs_first: bool = False):
  """Hi-NeRF parameters initialised from Lo-NeRF's.

  Layers of equal shape are copied; the rest (the view-direction branch, and
  the input layer over other features: the authors' option) keep their fresh
  initialisation. With `lo_inputs_first` (Hi-NeRF's encoding starts with Lo's
  P.E., `hi.encoding.with_lo`), a kernel whose inputs extend Lo's (the input
  and skip layers) gets Lo's rows first and zeros for the extra Hi features,
  so the Hi-NeRF starts as the same function as the Lo-NeRF.
  """
  flat_lo = dict(jax.tree_util.tree_leaves_with_path(lo_params))
  def pick(path, x):
    src = flat_lo.get(path)
    if src is None or src.ndim != x.ndim:
      return x
    # Without lo_inputs_first the input layer reads other features than Lo's,
    # even where the widths happen to agree.
    if not lo_inputs_first and any(getattr(k, "key", None) == "dense_0" for k in path):
      return x
    if src.shape == x.shape:
      return src
    if (lo_inputs_first and x.ndim == 2 and src.shape[1] == x.shape[1]
        and src.shape[0] < x.shape[0]):
      return jnp.zeros_like(x).at[:src.shape[0]].set(src)
    return x
  return jax.tree_util.tree_map_with_path(pick, hi_params)


def _loss_fn(params, data, key, step, *, model, cfg, near, far, white, guide_model, radius,
             mesh=None):
  """L_rec (+ coarse L_rec) + lambda L_empty for one batch drawn on device
  (split over `mesh`'s devices when data-parallel)."""
  k_idx, k_crop, k_ren, k_emp, k_emp_s = jax.random.split(key, 5)
  n_rays = data["origins"].shape[0]
  idx = jax.random.randint(k_idx, (cfg.batch_rays,), 0, n_rays)
  if cfg.precrop_steps > 0:
    crop = data["crop_idx"]
    idx_crop = crop[jax.random.randint(k_crop, (cfg.batch_rays,), 0, crop.shape[0])]
    idx = jnp.where(step < cfg.precrop_steps, idx_crop, idx)
  idx = parallel.shard_batch(idx, mesh)
  o, d, target = data["origins"][idx], data["dirs"][idx], data["rgb"][idx]
  guide = None
  if cfg.sampler.kind == "depth_guided":
    guide = field.Guide(guide_model, data["guide"], radius)
  outs = field.render_rays(model, cfg.sampler, params, o, d, k_ren, near=near, far=far,
                           white_background=white, randomized=True,
                           noise=cfg.density_noise, guide=guide)
  rec = losses.reconstruction(outs[-1]["rgb"], target)
  loss = rec
  if len(outs) > 1:
    loss = loss + cfg.sampler.coarse_weight * losses.reconstruction(outs[0]["rgb"], target)
  aux = {"psnr": metrics.mse_to_psnr(rec)}
  if cfg.empty.weight > 0:
    bank = data["empty"]
    j = bank["idx"][jax.random.randint(k_emp, (cfg.empty.num_rays,), 0, bank["idx"].shape[0])]
    j = parallel.shard_batch(j, mesh)
    eo, ed = bank["origins"][j], bank["dirs"][j]
    t = samplers.stratified(k_emp_s, jnp.full(j.shape, near), far, cfg.empty.num_samples)
    acc = field.composite(model, params, eo, ed, t, white)["acc"]
    l_empty = losses.empty_space(acc, bank["acc"][j], cfg.empty.tau)
    weight = jnp.where(step >= cfg.empty.start_step, cfg.empty.weight, 0.0)
    loss = loss + weight * l_empty
    aux["empty"] = l_empty
  return loss, aux


def train(config, dataset, workdir, name, lo_state=None, ray_state=None, log=None,
          wall_offset=0.0, mesh=None):
  """Trains the NeRF stage `name` ('lo' or 'hi') and returns its StageState.

  Args:
    config: the run config; the stage reads config[name].
    dataset: datasets.Dataset.
    workdir: run folder.
    name: 'lo' or 'hi'.
    lo_state: frozen Lo-NeRF (needed for L_empty and init_from_lo).
    ray_state: frozen ray field (needed for the depth-guided sampler).
    log, wall_offset, mesh: see loop.train.
  """
  cfg = config[name]
  parallel.check_batch(mesh, cfg.batch_rays, f"{name}.batch_rays")
  if cfg.empty.weight > 0:
    parallel.check_batch(mesh, cfg.empty.num_rays, f"{name}.empty.num_rays")
  near, far, white = dataset.near, dataset.far, dataset.white_background
  model = models.nerf_from_config(config, name)
  params = init_params(model, config.seed)
  if cfg.init_from_lo:
    if lo_state is None:
      raise ValueError(f"{name}.init_from_lo needs a finished 'lo' stage")
    if cfg.encoding.with_lo and (lo_state.config.lo.encoding.to_dict() !=
                                 config.lo.encoding.to_dict()):
      raise ValueError(f"{name}.encoding.with_lo: this run's lo.encoding "
                       f"{config.lo.encoding.to_dict()} differs from the finished Lo "
                       f"stage's {lo_state.config.lo.encoding.to_dict()}")
    params = transfer_from_lo(params, lo_state.params, cfg.encoding.with_lo)
  data = training_rays(dataset.train, cfg.precrop_frac)
  guide_model, radius = None, None
  if cfg.sampler.kind == "depth_guided":
    if ray_state is None:
      raise ValueError(f"{name}.sampler.kind='depth_guided' needs a finished 'ray' stage")
    guide_model = models.ray_field_from_config(ray_state.config.ray, near, far)
    radius = ray_state.config.ray.radius or dataset.radius
    data["guide"] = ray_state.params
  t0 = time.perf_counter()
  if cfg.empty.weight > 0:
    if lo_state is None:
      raise ValueError(f"{name}.empty.weight > 0 needs a finished 'lo' stage")
    bank = random_ray_bank(lo_state, cfg.empty.bank_rays, dataset.radius,
                           dataset.train.focal / dataset.train.width, near, far, white,
                           cfg.empty.num_samples, config.seed + 1, chunk=config.eval.chunk)
    empty_idx = np.flatnonzero(bank["acc"] < cfg.empty.tau).astype(np.int32)
    if empty_idx.size == 0:  # nothing is empty: the mask in L_empty makes it 0
      empty_idx = np.arange(bank["acc"].shape[0], dtype=np.int32)
    data["empty"] = {"origins": bank["origins"], "dirs": bank["dirs"], "acc": bank["acc"],
                     "idx": empty_idx}
  data = jax.device_put(data)
  bank_s = time.perf_counter() - t0  # rendering the Lo bank counts as training time
  cfg = loop.minus_seconds(cfg, bank_s)
  loss_fn = functools.partial(_loss_fn, model=model, cfg=cfg, near=near, far=far, white=white,
                              guide_model=guide_model, radius=radius, mesh=mesh)

  render_eval = field.make_eval_fn(model, cfg.sampler, near=near, far=far,
                                   white_background=white, guide_model=guide_model,
                                   radius=radius)
  guide_params = ray_state.params if guide_model is not None else None
  make_eval = lambda p: functools.partial(render_eval, p, guide_params)

  def eval_fn(params):
    return {"psnr": evaluate.heldout_psnr(make_eval(params), dataset.test, config.eval.chunk,
                                          config.eval.curve_views)}

  params, step, info = loop.train(name, cfg, workdir, params, loss_fn, data, config.seed,
                                  eval_fn, log, wall_offset + bank_s, mesh)
  info["wall_s"] += bank_s
  state = StageState(params, step, config, name)
  info["eval"] = evaluate.evaluate(make_eval(params), dataset.test, config.eval.chunk,
                                   os.path.join(stage_dir(workdir, name), "eval"), near, far,
                                   config.eval.save_images, config.eval.lpips)
  return state, info
