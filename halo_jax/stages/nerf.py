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

from halo_jax import (camera, evaluate, lightfield, losses, metrics, models, parallel,
                      samplers)
from halo_jax.stages import field, loop
from halo_jax.stages.state import StageState, stage_dir


def init_params(model, seed):
  pts = jnp.zeros((1, 3))
  if isinstance(model, models.DeformNeRF):
    return model.init(jax.random.PRNGKey(seed), pts, pts, times=jnp.zeros((1, 1)))["params"]
  return model.init(jax.random.PRNGKey(seed), pts, pts)["params"]


def init_params_ray(model, seed):
  x = jnp.zeros((1, 3))
  return model.init(jax.random.PRNGKey(seed), x, x)["params"]


def training_rays(views, precrop_frac):
  """All training pixels as flat rays, plus the indices inside the centre crop.

  Returns dict of numpy arrays: origins, dirs, rgb [R, 3], crop_idx [Rc], and
  for a dynamic scene times [R, 1].
  """
  o, d = views.rays()
  n, h, w = views.images.shape[:3]
  dh, dw = int(h * precrop_frac / 2), int(w * precrop_frac / 2)
  mask = np.zeros((n, h, w), bool)
  mask[:, h // 2 - dh:h // 2 + dh, w // 2 - dw:w // 2 + dw] = True
  out = {"origins": o.reshape(-1, 3), "dirs": d.reshape(-1, 3),
         "rgb": views.images.reshape(-1, 3),
         "crop_idx": np.flatnonzero(mask.reshape(-1)).astype(np.int32)}
  if views.times is not None:
    out["times"] = np.ascontiguousarray(views.ray_times().reshape(-1, 1))
  return out


def random_ray_bank(lo_state: StageState, num_rays, radius, focal_over_width, near, far,
                    white_background, num_samples, seed, target="max_weight", chunk=8192,
                    block_rays=0):
  """Random hemisphere rays rendered once by the frozen Lo-NeRF.

  The Lo field is frozen, so its depth and opacity on a fixed bank of random
  rays are exact targets; rendering them once instead of every step is the
  saving (the bank's size is the only approximation).

  For a dynamic Lo field every ray also gets a random time in [0, 1] (the
  regulariser then covers times no training view shows).

  Returns dict: origins, dirs [B, 3], depth, acc [B] (numpy), times [B, 1]
  (dynamic only).
  """
  lo_model = models.nerf_from_config(lo_state.config, "lo")
  k_rays, k_time = jax.random.split(jax.random.PRNGKey(seed))
  o, d = camera.random_hemisphere_rays(k_rays, num_rays, radius, focal_over_width)
  times = None
  if models.is_dynamic(lo_state.config, "lo"):
    times = np.asarray(jax.random.uniform(k_time, (num_rays, 1)))
  fn = lambda oo, dd, tt=None: dict(zip(("depth", "acc"), field.lo_targets(
      lo_model, lo_state.params, oo, dd, num_samples=num_samples, near=near, far=far,
      white_background=white_background, target=target, times=tt, block_rays=block_rays)))
  out = field.render_chunked(jax.jit(fn), np.asarray(o), np.asarray(d), chunk, times)
  bank = {"origins": np.asarray(o), "dirs": np.asarray(d), **out}
  if times is not None:
    bank["times"] = times
  return bank


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


def joint_window(cfg, step):
  """The joint sampler's half window at `step` (a fraction of far - near):
  alpha, falling linearly from 1 to joint.alpha_final (SPEC sec. 4)."""
  return lightfield.alpha_schedule(step, cfg.joint.alpha_steps, cfg.joint.alpha_final)


def _loss_fn(params, data, key, step, part=None, *, model, cfg, near, far, white,
             guide_model, radius, mesh=None):
  """L_rec (+ coarse L_rec) + lambda L_empty (+ L_consist for the joint
  sampler) for one batch drawn on device (split over `mesh`'s devices when
  data-parallel), or for its `part` (loop.part_of: the training rays and the
  L_empty rays are cut alike, and every ray keeps its own PRNG key)."""
  joint = cfg.sampler.kind == "joint"
  if joint:
    params, ray_params = params["nerf"], params["ray"]
  k_idx, k_crop, k_ren, k_emp, k_emp_s = jax.random.split(key, 5)
  n_rays = data["origins"].shape[0]
  idx = jax.random.randint(k_idx, (cfg.batch_rays,), 0, n_rays)
  if cfg.precrop_steps > 0:
    crop = data["crop_idx"]
    idx_crop = crop[jax.random.randint(k_crop, (cfg.batch_rays,), 0, crop.shape[0])]
    idx = jnp.where(step < cfg.precrop_steps, idx_crop, idx)
  keys = loop.part_of(jax.random.split(k_ren, cfg.batch_rays), part)
  idx = parallel.shard_batch(loop.part_of(idx, part), mesh)
  o, d, target = data["origins"][idx], data["dirs"][idx], data["rgb"][idx]
  times = data["times"][idx] if "times" in data else None
  guide, window = None, None
  if cfg.sampler.kind == "depth_guided":
    guide = field.Guide(guide_model, data["guide"], radius)
  elif joint:
    guide = field.Guide(guide_model, ray_params, radius)
    window = joint_window(cfg, step)
  outs = field.render_rays(model, cfg.sampler, params, o, d, keys, near=near, far=far,
                           white_background=white, randomized=True,
                           noise=cfg.density_noise, guide=guide, times=times, window=window)
  rec = losses.reconstruction(outs[-1]["rgb"], target)
  loss = rec
  if len(outs) > 1:
    loss = loss + cfg.sampler.coarse_weight * losses.reconstruction(outs[0]["rgb"], target)
  aux = {"psnr": metrics.mse_to_psnr(rec)}
  if joint:
    # L_consist: the ray field trained in this step follows the frozen Lo
    # field's depth and opacity on these rays (L_ray's form).
    depth, acc = field.ray_field_depth(guide, o, d)
    consist = losses.ray_field(depth, acc, data["lo_depth"][idx], data["lo_acc"][idx], far)
    loss = loss + cfg.joint.consist_weight * consist
    aux.update(consist=consist, alpha=window)
  if cfg.empty.weight > 0:
    bank = data["empty"]
    j = bank["idx"][jax.random.randint(k_emp, (cfg.empty.num_rays,), 0, bank["idx"].shape[0])]
    keys_emp = loop.part_of(jax.random.split(k_emp_s, cfg.empty.num_rays), part)
    j = parallel.shard_batch(loop.part_of(j, part), mesh)
    eo, ed = bank["origins"][j], bank["dirs"][j]
    et = bank["times"][j] if "times" in bank else None
    t = samplers.stratified(keys_emp, jnp.full(j.shape, near), far, cfg.empty.num_samples)
    acc = field.composite(model, params, eo, ed, t, white, times=et)["acc"]
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
  loop.check_parts(cfg, cfg.batch_rays, f"{name}.batch_rays", mesh)
  if cfg.empty.weight > 0:
    loop.check_parts(cfg, cfg.empty.num_rays, f"{name}.empty.num_rays", mesh)
  near, far, white = dataset.near, dataset.far, dataset.white_background
  dynamic = models.is_dynamic(config, name)
  if dynamic != (dataset.train.times is not None):
    raise ValueError(
        f"{name}.model.kind={cfg.model.kind!r} but the data ({config.data.kind!r}) is "
        f"{'dynamic (frames carry times)' if dataset.train.times is not None else 'static'}: "
        "use model.kind='deform' for dynamic scenes and 'nerf' for static ones")
  if dynamic and field.uses_guide(cfg.sampler):
    raise ValueError(f"{name}.sampler.kind='depth_guided' needs a ray field, which has no "
                     "time input; dynamic scenes use 'stratified' or 'hierarchical'")
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
  joint = cfg.sampler.kind == "joint"
  if joint:
    # The ray field trains with this stage; its targets are the frozen
    # Lo-NeRF's depth and opacity on the training rays (rendered once).
    if lo_state is None:
      raise ValueError(f"{name}.sampler.kind='joint' needs a finished 'lo' stage")
    guide_model = models.ray_field_from_config(config.ray, near, far)
    radius = config.ray.radius or dataset.radius
    params = {"nerf": params, "ray": init_params_ray(guide_model, config.seed)}
    lo_model = models.nerf_from_config(lo_state.config, "lo")
    fn = lambda oo, dd: dict(zip(("depth", "acc"), field.lo_targets(
        lo_model, lo_state.params, oo, dd, num_samples=lo_state.config.lo.sampler.num_samples,
        near=near, far=far, white_background=white, target=config.ray.depth_target,
        block_rays=config.eval.block_rays)))
    targets = field.render_chunked(jax.jit(fn), data["origins"], data["dirs"],
                                   config.eval.chunk)
    data.update(lo_depth=targets["depth"], lo_acc=targets["acc"])
  if cfg.empty.weight > 0:
    if lo_state is None:
      raise ValueError(f"{name}.empty.weight > 0 needs a finished 'lo' stage")
    bank = random_ray_bank(lo_state, cfg.empty.bank_rays, dataset.radius,
                           dataset.train.focal / dataset.train.width, near, far, white,
                           cfg.empty.num_samples, config.seed + 1, chunk=config.eval.chunk,
                           block_rays=config.eval.block_rays)
    empty_idx = np.flatnonzero(bank["acc"] < cfg.empty.tau).astype(np.int32)
    if empty_idx.size == 0:  # nothing is empty: the mask in L_empty makes it 0
      empty_idx = np.arange(bank["acc"].shape[0], dtype=np.int32)
    data["empty"] = {"origins": bank["origins"], "dirs": bank["dirs"], "acc": bank["acc"],
                     "idx": empty_idx}
    if "times" in bank:
      data["empty"]["times"] = bank["times"]
  data = jax.device_put(data)
  bank_s = time.perf_counter() - t0  # rendering the Lo bank counts as training time
  cfg = loop.minus_seconds(cfg, bank_s)
  loss_fn = functools.partial(_loss_fn, model=model, cfg=cfg, near=near, far=far, white=white,
                              guide_model=guide_model, radius=radius, mesh=mesh)

  render_eval = field.make_eval_fn(model, cfg.sampler, near=near, far=far,
                                   white_background=white, guide_model=guide_model,
                                   radius=radius, block_rays=config.eval.block_rays)
  guide_params = ray_state.params if cfg.sampler.kind == "depth_guided" else None

  def make_eval(p, step=None):
    if joint:  # the window the joint sampler trains with at this step
      return functools.partial(render_eval, p["nerf"], p["ray"],
                               window=joint_window(cfg, cfg.steps if step is None else step))
    return functools.partial(render_eval, p, guide_params)

  def eval_fn(params, step=None):
    return {"psnr": evaluate.heldout_psnr(make_eval(params, step), dataset.test,
                                          config.eval.chunk, config.eval.curve_views)}

  params, step, info = loop.train(name, cfg, workdir, params, loss_fn, data, config.seed,
                                  eval_fn, log, wall_offset + bank_s, mesh)
  info["wall_s"] += bank_s
  state = StageState(params, step, config, name)
  eval_dir = os.path.join(stage_dir(workdir, name), "eval")
  info["eval"] = evaluate.evaluate(make_eval(params, step), dataset.test, config.eval.chunk,
                                   eval_dir, near, far, config.eval.save_images,
                                   config.eval.lpips)
  if dynamic:
    info["eval"]["flicker"] = evaluate.flicker(
        make_eval(params, step), dataset.test, config.eval.chunk, config.eval.flicker_frames,
        eval_dir if config.eval.save_images else None)
  return state, info
