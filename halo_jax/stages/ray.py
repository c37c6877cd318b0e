"""The ray-field stage: distil the frozen Lo-NeRF's depth and opacity into a
light-field network that answers with one MLP query per ray."""
import functools
import time
from typing import NamedTuple, Optional

import jax
import jax.numpy as jnp
import numpy as np

from halo_jax import geometry, losses, models, parallel, ray_fields, raycast, registry, rng
from halo_jax.rays import Rays, Targets
from halo_jax.stages import base, budget, collapse, lo_targets, loop, microbatch
from halo_jax.stages.state import StageState

TEACHER = "lo"  # the stage whose depth and opacity the ray field learns
# Random rays come from cameras on the upper hemisphere round a 360-degree
# scene and from mixes of the training rays of a forward-facing one (NDC):
# every geometry the stage takes (geometry.SPATIAL) has them.


def requires(config, name):
  return (TEACHER,)


def check(config, name, dspec):
  cfg = config[name]
  registry.check(not dspec.dynamic, f"the ray field has no time input; data.kind="
                 f"{config.data.kind!r} has frames with times: leave the '{name}' stage out")
  registry.check(cfg.depth_target in raycast.DEPTH_TARGETS,
                 f"{name}.depth_target={cfg.depth_target!r}: must be one of "
                 f"{list(raycast.DEPTH_TARGETS)}")
  registry.check(cfg.acc_weight >= 0, f"{name}.acc_weight={cfg.acc_weight!r}: must be >= 0")


def init_params(config, name, dataset):
  model = ray_fields.ray_field_from_config(config[name], dataset.near, dataset.far,
                                           models.sin_cos_of(config))
  return {"ray": ray_fields.init_ray_field(model, config.seed)}


class RayStageData(NamedTuple):
  """Lo-NeRF's targets on the training rays and on a bank of random
  hemisphere rays (None without random rays)."""
  train: Targets
  random: Optional[Targets]


def loss_fn(params, data: RayStageData, key, step, part=None, *, model, guide_geometry, radius,
            far, n_train, n_random, acc_weight=1.0, random_acc=True, mesh=None):
  """L_ray on a batch of training rays and random rays (or on the batch's
  `part`, microbatch.part_of: each source is cut alike); random_acc False
  leaves the random rays' opacity out of it."""
  k_t, k_r = jax.random.split(key)
  sources, weights = [], []
  for k, src, n, w in ((k_t, data.train, n_train, acc_weight),
                       (k_r, data.random, n_random, acc_weight if random_acc else 0.0)):
    if n:
      i = microbatch.part_of(jax.random.randint(k, (n,), 0, src.depth.shape[0]), part)
      sources.append(src.take(i))
      weights.append(jnp.full(i.shape, w, jnp.float32))
  batch = jax.tree_util.tree_map(
      lambda *xs: parallel.shard_batch(jnp.concatenate(xs), mesh), *sources)
  if not random_acc and n_random:
    acc_weight = parallel.shard_batch(jnp.concatenate(weights), mesh)
  guide = raycast.Guide(model, params["ray"], guide_geometry, radius)
  depth, acc = raycast.ray_field_depth(guide, batch.rays.origins, batch.rays.dirs)
  loss = losses.ray_field(depth, acc, batch.depth, batch.acc, far, acc_weight)
  return loss, {"depth_rmse": jnp.sqrt(jnp.mean((depth - batch.depth) ** 2)),
                "acc_mae": jnp.mean(jnp.abs(acc - batch.acc))}


def _targets(ctx, lo_samples, n_random, radius) -> RayStageData:
  """Lo-NeRF's depth and opacity on the training rays (or `target_rays` of
  them, drawn once) and on a bank of random rays (numpy): from hemisphere
  cameras, or in NDC between the training rays."""
  config, cfg, ds = ctx.config, ctx.cfg, ctx.dataset
  lo = ctx.states[TEACHER]
  o, d = ds.train.rays()
  o, d = o.reshape(-1, 3), d.reshape(-1, 3)
  all_o, all_d = o, d
  if 0 < cfg.target_rays < o.shape[0]:
    pick = np.random.default_rng(rng.stream_seed(config.seed, rng.Stream.RAY_TARGET_RAYS))
    keep = np.sort(pick.choice(o.shape[0], cfg.target_rays, replace=False))
    o, d = o[keep], d[keep]
  common = dict(near=ds.near, far=ds.far, white_background=ds.white_background,
                target=cfg.depth_target, chunk=config.eval.chunk,
                block_rays=config.eval.block_rays)
  train = lo_targets.on_rays(lo, Rays(o, d), num_samples=lo_samples, **common)
  random, bank_seed = None, rng.stream_seed(config.seed, rng.Stream.RAY_RANDOM_BANK)
  if n_random and ds.geometry == geometry.Geometry.NDC:
    random = lo_targets.between_ray_bank(lo, cfg.bank_rays, all_o, all_d, ds.near, ds.far,
                                         ds.white_background, lo_samples, bank_seed,
                                         cfg.depth_target, config.eval.chunk,
                                         config.eval.block_rays)
  elif n_random:
    random = lo_targets.random_ray_bank(
        lo, cfg.bank_rays, radius, ds.train.focal / ds.train.width, ds.near, ds.far,
        ds.white_background, lo_samples, bank_seed, cfg.depth_target,
        config.eval.chunk, config.eval.block_rays)
  return RayStageData(train, random)


def train(ctx: base.StageContext):
  """Trains the ray field on Lo-NeRF targets; returns (StageState, info).

  Targets are rendered once at the start (training rays and a bank of random
  hemisphere rays); that time counts as this stage's training time.
  """
  config, name, ds = ctx.config, ctx.name, ctx.dataset
  cfg = ctx.cfg
  radius = ray_fields.guide_radius(cfg, ds)
  model = ray_fields.ray_field_from_config(cfg, ds.near, ds.far,
                                           models.sin_cos_of(config))
  lo_samples = cfg.lo_samples or ctx.states[TEACHER].config.lo.sampler.num_samples
  n_random = int(round(cfg.batch_rays * cfg.random_fraction)) if cfg.bank_rays else 0
  microbatch.check_parts(cfg, cfg.batch_rays - n_random, f"{name}.batch_rays (training rays)", ctx.mesh)
  microbatch.check_parts(cfg, n_random, f"{name}.batch_rays (random rays)", ctx.mesh)
  t0 = time.perf_counter()
  data = _targets(ctx, lo_samples, n_random, radius)
  target_s = time.perf_counter() - t0
  data = jax.device_put(data)
  step_loss = functools.partial(loss_fn, model=model, guide_geometry=ds.geometry, radius=radius,
                                far=ds.far, n_train=cfg.batch_rays - n_random,
                                n_random=n_random, acc_weight=cfg.acc_weight,
                                random_acc=cfg.random_acc, mesh=ctx.mesh)
  cfg = budget.minus_seconds(cfg, target_s)
  # each target source with its rays per batch, as loss_fn draws them
  shares = [(src, n) for src, n in ((data.train, cfg.batch_rays - n_random),
                                    (data.random, n_random)) if n]
  baseline = collapse.targets_baseline([np.asarray(src.depth) for src, _ in shares],
                                       [np.asarray(src.acc) for src, _ in shares], ds.far,
                                       [n for _, n in shares])
  params, step, info = loop.train(name, cfg, ctx.workdir, init_params(config, name, ds),
                                  step_loss, data, config.seed, None, ctx.log,
                                  ctx.wall_offset + target_s, ctx.mesh,
                                  snapshot_s=ctx.front_s, pacer=ctx.pacer, baseline=baseline)
  info["wall_s"] += target_s
  info.update(target_s=target_s, setup_s=target_s, target_rays=int(data.train.depth.shape[0]))
  return StageState(params, step, config, name), info


base.TRAINERS.register("ray_field", base.Trainer(
    requires=requires, params_like=init_params, train=train, check=check,
    geometries=geometry.SPATIAL))
