"""The ray field stage: distil the frozen Lo-NeRF's depth and opacity into a
light-field network that answers with one MLP query per ray."""
import functools
import time

import jax
import jax.numpy as jnp
from halo_jax import losses, models, parallel
from halo_jax.stages import field, loop, nerf
from halo_jax.stages.state import StageState


def init_params(model, seed):
  x = jnp.zeros((1, 3))
  return model.init(jax.random.PRNGKey(seed), x, x)["params"]


def _loss_fn(params, data, key, step, part=None, *, model, radius, far, n_train, n_random,
             mesh=None):
  """L_ray on a batch of training rays and random hemisphere rays (or on the
  batch's `part`, loop.part_of: each source is cut alike)."""
  k_t, k_r = jax.random.split(key)
  sources = []
  for k, src, n in ((k_t, data["train"], n_train), (k_r, data.get("random"), n_random)):
    if n:
      i = loop.part_of(jax.random.randint(k, (n,), 0, src["origins"].shape[0]), part)
      sources.append({f: v[i] for f, v in src.items()})
  batch = {f: parallel.shard_batch(jnp.concatenate([p[f] for p in sources]), mesh)
           for f in sources[0]}
  depth, acc = field.ray_field_depth(field.Guide(model, params, radius), batch["origins"],
                                     batch["dirs"])
  loss = losses.ray_field(depth, acc, batch["depth"], batch["acc"], far)
  return loss, {"depth_rmse": jnp.sqrt(jnp.mean((depth - batch["depth"]) ** 2)),
                "acc_mae": jnp.mean(jnp.abs(acc - batch["acc"]))}


def train(config, dataset, workdir, lo_state: StageState, log=None, wall_offset=0.0,
          mesh=None):
  """Trains the ray field on Lo-NeRF targets; returns (StageState, info).

  Targets are rendered once at the start (training rays and a bank of random
  hemisphere rays); that time counts as this stage's training time.
  """
  cfg = config.ray
  near, far, white = dataset.near, dataset.far, dataset.white_background
  radius = cfg.radius or dataset.radius
  model = models.ray_field_from_config(cfg, near, far)
  lo_model = models.nerf_from_config(lo_state.config, "lo")
  lo_samples = cfg.lo_samples or lo_state.config.lo.sampler.num_samples
  t0 = time.perf_counter()
  rays = nerf.training_rays(dataset.train, 1.0)
  fn = lambda o, d: dict(zip(("depth", "acc"), field.lo_targets(
      lo_model, lo_state.params, o, d, num_samples=lo_samples, near=near, far=far,
      white_background=white, target=cfg.depth_target, block_rays=config.eval.block_rays)))
  train_targets = field.render_chunked(jax.jit(fn), rays["origins"], rays["dirs"],
                                       config.eval.chunk)
  data = {"train": {"origins": rays["origins"], "dirs": rays["dirs"], **train_targets}}
  n_random = int(round(cfg.batch_rays * cfg.random_fraction)) if cfg.bank_rays else 0
  loop.check_parts(cfg, cfg.batch_rays - n_random, "ray.batch_rays (training rays)", mesh)
  loop.check_parts(cfg, n_random, "ray.batch_rays (random rays)", mesh)
  if n_random:
    data["random"] = nerf.random_ray_bank(
        lo_state, cfg.bank_rays, radius, dataset.train.focal / dataset.train.width, near, far,
        white, lo_samples, config.seed + 2, cfg.depth_target, config.eval.chunk,
        config.eval.block_rays)
  target_s = time.perf_counter() - t0
  data = jax.device_put(data)
  loss_fn = functools.partial(_loss_fn, model=model, radius=radius, far=far,
                              n_train=cfg.batch_rays - n_random, n_random=n_random, mesh=mesh)
  cfg = loop.minus_seconds(cfg, target_s)
  params, step, info = loop.train("ray", cfg, workdir, init_params(model, config.seed),
                                  loss_fn, data, config.seed, None, log,
                                  wall_offset + target_s, mesh)
  info["wall_s"] += target_s
  info["target_s"] = target_s
  return StageState(params, step, config, "ray"), info
