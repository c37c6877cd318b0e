"""The radiance-field stage for two-plane light fields (docs/scene_kinds.md).

The field is an EPINeRF over (s', t', theta); every ray is rendered over the
angle range [theta_n, theta_f], parameterised by tau in [0, 1].
- sampler.kind='stratified': samples over the whole range (the NeRF baseline).
- sampler.kind='joint' (HALO): a low-frequency EPIRayField, trained in the
  same step, predicts tau_ray for each ray; the samples fill
  tau_ray +- alpha, alpha falling from 1 to joint.alpha_final, and the ray
  field follows the radiance field's expected tau through
  L_consist = |tau_ray - tau_nerf|^2 (tau_nerf held fixed in that loss).
  Options from the authors' code and the paper, off by default
  (docs/scene_kinds.md): random rays between the cameras, a colour head on
  the ray field, and L_consist into the radiance field as well.
With `random_background`, training rays are composited onto a random colour
(either sampler), so every ray must end in something opaque.
"""
import functools
import os

import jax
import jax.numpy as jnp
import numpy as np

from halo_jax import (evaluate, geometry, lightfield, losses, metrics, models, parallel,
                      ray_fields, raycast, registry, render, rng, samplers)
from halo_jax.rays import Batch, Rays
from halo_jax.stages import base, batches, collapse, loop, microbatch, terms
from halo_jax.stages.radiance import joint_window
from halo_jax.stages.state import StageState, stage_dir


def requires(config, name):
  return ()


def check(config, name, dspec):
  cfg = config[name]
  spec = samplers.SAMPLERS.get(cfg.sampler.kind, f"{name}.sampler.kind")
  kinds = [k for k, v in samplers.SAMPLERS.items() if geometry.Geometry.TWO_PLANE in v.geometries]
  registry.check(geometry.Geometry.TWO_PLANE in spec.geometries,
                 f"{name}.sampler.kind={cfg.sampler.kind!r}: light fields use one of {kinds}")
  registry.check(cfg.model.get("kind") == "epi",
                 f"{name}.model.kind={cfg.model.get('kind')!r}: the light-field stage "
                 "renders an 'epi' field")
  terms.check_geometries(cfg, name, dspec, f"data.kind={config.data.kind!r} "
                         f"({dspec.geometry.value} rays)")
  registry.check(cfg.joint.get("field", "oblique") in ("oblique", "nelf"),
                 f"{name}.joint.field={cfg.joint.get('field')!r}: use 'oblique' or 'nelf'")
  registry.check(not cfg.joint.get("random_full", False)
                 or _sampler(cfg).guided_edges is not None,
                 f"{name}.joint.random_full=True: the random rays' full range is a blended "
                 "window of width 0; use sampler.kind 'joint_blended' or 'joint_blended_even'")
  n_full = full_range_samples(cfg)
  registry.check(n_full == 0 or cfg.sampler.num_samples - n_full - 1 >= 1,
                 f"{name}.joint.full_range={cfg.joint.full_range}: its {n_full} full-range "
                 f"samples leave no window samples of {name}.sampler.num_samples="
                 f"{cfg.sampler.num_samples}")
  # The EPI field's Fourier features have no ordered bands to open one by one.
  registry.check(cfg.freq_reg.end == 0.0,
                 f"{name}.freq_reg.end={cfg.freq_reg.end!r}: the light-field stage has no "
                 "P.E. bands to schedule (FreeNeRF's mask); set it to 0")


def init_params(model, ray_model, seed):
  """{'nerf': ...} plus {'ray': ...} for the joint sampler."""
  k_nerf, k_ray = jax.random.split(jax.random.PRNGKey(seed))
  params = {"nerf": model.init(k_nerf, jnp.zeros((1, 3)), jnp.zeros((1, 2)))["params"]}
  if ray_model is not None:
    params["ray"] = ray_model.init(k_ray, jnp.zeros((1, 4)))["params"]
  return params


def models_from_config(config, name):
  cfg = config[name]
  sin_cos = models.sin_cos_of(config)
  ray_model = ray_fields.epi_ray_field_from_config(cfg.joint, sin_cos) \
      if _sampler(cfg).trains_guide else None
  return models.nerf_from_config(config, name), ray_model


def _sampler(cfg):
  return samplers.SAMPLERS.get(cfg.sampler.kind, "sampler.kind")


def full_range_samples(cfg) -> int:
  """The guided sampler's samples spread over the whole range
  (joint.full_range of sampler.num_samples); 0 for an unguided one."""
  if not _sampler(cfg).guided:
    return 0
  return int(round(cfg.joint.full_range * cfg.sampler.num_samples))


def ray_field_tau(ray_model, params, uv, st):
  """The ray field's tau_ray [R] on rays uv, st [R, 2], and its colour rgb_ray
  [R, 3] where it has a colour head (else None)."""
  out = ray_model.apply({"params": params}, jnp.concatenate([uv, st], -1))
  return out if ray_model.color else (out, None)


def render_rays(model, ray_model, cfg, params, rays: Rays, key, alpha, *, theta_n, theta_f,
                randomized, noise=0.0, slope="angle"):
  """Renders two-plane rays [R] (origins (u, v, 0), dirs (s, t, 1)) with the
  stage's sampler (cfg: sampler, joint): EPINeRF `model` and, where the
  sampler trains its guide ('joint'), EPIRayField `ray_model`, params
  {'nerf'[, 'ray']}; per-ray keys [R, 2] (one key when nothing is drawn);
  alpha: the joint window's scale; tau spans theta_n..theta_f (angles, or
  depths with slope 'depth': lightfield.SLOPES, the dataset's epi_slope).
  Returns raycast.composite's dict (depth = expected tau) plus tau_ray [R]
  for the joint sampler and rgb_ray [R, 3] (None without a colour head).
  """
  uv, st = rays.origins[:, :2], rays.dirs[:, :2]
  keys = raycast.per_ray_keys(key, uv.shape[0], randomized, noise)
  k_s, k_n = rng.split(keys, 2)
  spec = _sampler(cfg)
  tau_ray = rgb_ray = None
  if spec.trains_guide:
    tau_ray, rgb_ray = ray_field_tau(ray_model, params["ray"], uv, st)
  guide = None if tau_ray is None else jax.lax.stop_gradient(tau_ray)
  edges = functools.partial(spec.edges, cfg.sampler, near=0.0, far=1.0, window=alpha,
                            num_full=full_range_samples(cfg), randomized=randomized)
  t = jax.vmap(lambda k, g: edges(k, guide_depth=g))(k_s, guide)
  points = functools.partial(lightfield.ray_points, theta_n=theta_n, theta_f=theta_f,
                             slope=slope)
  out = raycast.composite(model, params["nerf"], uv, st, t, False, k_n, noise,
                          points_of=points)
  out["tau_ray"], out["rgb_ray"] = tau_ray, rgb_ray
  return out


def consist_target(out, target: str):
  """tau_nerf [R]: the radiance field's expected tau, or the tau of its
  largest weight (the mode, which a diffuse density does not pull towards the
  window's centre)."""
  if target == "expected":
    return render.normalized_depth(out["depth"], out["acc"])
  if target == "max_weight":
    return out["depth_max"]
  raise ValueError(f"joint.target={target!r}: use 'expected' or 'max_weight'")


def consist_loss(out, target: str):
  """L_consist over a render's rays with tau_nerf held fixed, so it trains
  the ray field only."""
  tau_nerf = jax.lax.stop_gradient(consist_target(out, target))
  return losses.consistency(out["tau_ray"], tau_nerf)


def with_random_background(rgb, acc, keys):
  """rgb [R, 3] composited onto a uniform random colour per ray (from the
  per-ray keys [R, 2]): rgb + u (1 - acc). A ray left partly transparent
  then renders noise, so every training ray must end in something opaque
  (the authors' light-field code does this; the scenes fill every pixel)."""
  u = rng.uniform(jax.vmap(lambda k: jax.random.fold_in(k, 2))(keys), rgb.shape)
  return rgb + u * (1.0 - acc[..., None])


def loss_fn(params, data: batches.StageData, key, step, part=None, *, model, ray_model, cfg,
            theta_n, theta_f, mesh=None, slope="angle"):
  """L_rec plus the stage's active loss terms (terms.TERMS: the light-field
  ones below) on the batch, or on its `part` (microbatch.part_of)."""
  k_idx, k_ren = jax.random.split(key)
  px = data.pixels
  idx = batches.draw(k_idx, None, step, px.rgb.shape[0], cfg.batch_rays, None, 0)
  keys = jax.random.split(k_ren, cfg.batch_rays)  # per ray: parts draw as the whole
  idx, keys = microbatch.part_of(idx, part), microbatch.part_of(keys, part)
  idx = parallel.shard_batch(idx, mesh)
  batch = Batch(px.rays.take(idx), px.rgb[idx], idx)
  window = joint_window(cfg, step)
  out = render_rays(model, ray_model, cfg, params, batch.rays, keys, window, theta_n=theta_n,
                    theta_f=theta_f, randomized=True, noise=cfg.density_noise, slope=slope)
  if cfg.random_background:
    out = dict(out, rgb=with_random_background(out["rgb"], out["acc"], keys))
  # fold_in leaves the training rays' keys as they are whatever the terms draw
  x = terms.Inputs(params, model, [out], batch, data, (jax.random.fold_in(key, 1),), part, mesh,
                   theta_n, theta_f, False, None,
                   {"ray_model": ray_model, "window": window, "step": step, "slope": slope})
  loss, aux = terms.total(cfg, step, x, terms.active_terms(cfg))
  if out["tau_ray"] is not None:
    aux["alpha"] = window
  return loss, aux


def _joint(cfg):
  return cfg.kind == "light_field" and _sampler(cfg).trains_guide


def _consist_value(x, cfg):
  value = consist_loss(x.outs[0], cfg.joint.target)
  return value, {"consist": value}


def _pull_value(x, cfg):
  # the other half of the paper's L_consist, which the authors' code
  # detaches: the radiance field's tau pulled towards the ray field's
  out = x.outs[0]
  value = losses.consistency(jax.lax.stop_gradient(out["tau_ray"]),
                             consist_target(out, cfg.joint.target))
  return value, {}


def _color_value(x, cfg):
  # the ray field's colour head on the pixels (the authors' nelf_rec_loss)
  value = losses.reconstruction(x.outs[0]["rgb_ray"], x.batch.rgb)
  return value, {"ray_psnr": metrics.mse_to_psnr(value)}


def _random_value(x, cfg):
  random, color = _random_ray_consist(x.params, x.data.terms["lf_random"], x.keys[0],
                                      x.extra["step"],
                                      x.part, model=x.model, ray_model=x.extra["ray_model"],
                                      cfg=cfg, theta_n=x.near, theta_f=x.far, mesh=x.mesh,
                                      slope=x.extra["slope"])
  value, aux = cfg.joint.consist_weight * random, {"consist_random": random}
  if color is not None:
    value = value + cfg.joint.color_weight * color
    aux["color_random"] = color
  return value, aux


_TWO_PLANE = frozenset({geometry.Geometry.TWO_PLANE})
terms.TERMS.register("lf_consist", terms.Term(
    active=_joint, weight=lambda cfg, step: cfg.joint.consist_weight, value=_consist_value,
    geometries=_TWO_PLANE))
terms.TERMS.register("lf_nerf_consist", terms.Term(
    active=lambda cfg: _joint(cfg) and cfg.joint.nerf_consist_weight > 0,
    weight=lambda cfg, step: cfg.joint.nerf_consist_weight, value=_pull_value,
    geometries=_TWO_PLANE))
terms.TERMS.register("lf_color", terms.Term(
    active=lambda cfg: _joint(cfg) and cfg.joint.color_weight > 0,
    weight=lambda cfg, step: cfg.joint.color_weight, value=_color_value, geometries=_TWO_PLANE))
# L_consist (and the colour head's loss) on random rays between the cameras;
# its value carries the two weights itself, so its own weight is 1.
terms.TERMS.register("lf_random", terms.Term(
    active=lambda cfg: _joint(cfg) and cfg.joint.random_rays > 0,
    weight=lambda cfg, step: 1.0, value=_random_value, prepare=lambda s: camera_box(s.pixels),
    geometries=_TWO_PLANE))


def _random_ray_consist(params, box, key, step, part, *, model, ray_model, cfg, theta_n,
                        theta_f, mesh=None, slope="angle"):
  """L_consist on joint.random_rays rays between the training cameras.

  (u, v, s, t) uniform in the training rays' box [2 (min, max), 4]
  (camera_box). The radiance field is rendered with the current window
  but held fixed (stop_gradient): only the ray field learns here, following
  the radiance field at views no camera saw, where held-out views lie. With
  a colour head the ray field's colour also follows the radiance field's.

  Returns the mean squared tau difference and the ray field's mean squared
  colour difference (None without a colour head), scalars.
  """
  n = cfg.joint.random_rays
  k_uv, k_st, k_ren = jax.random.split(key, 3)
  uv = jax.random.uniform(k_uv, (n, 2), minval=box[0, :2], maxval=box[1, :2])
  st = jax.random.uniform(k_st, (n, 2), minval=box[0, 2:], maxval=box[1, 2:])
  keys = jax.random.split(k_ren, n)
  uv, st, keys = (parallel.shard_batch(microbatch.part_of(x, part), mesh) for x in (uv, st, keys))
  frozen = dict(params, nerf=jax.lax.stop_gradient(params["nerf"]))
  rays = two_plane_rays(uv, st)
  # random_full: the radiance field's answer over the whole range, not the
  # ray field's window (their LLFF code); a blended window of width 0 is it
  window = 0.0 if cfg.joint.get("random_full", False) else joint_window(cfg, step)
  out = render_rays(model, ray_model, cfg, frozen, rays, keys, window,
                    theta_n=theta_n, theta_f=theta_f, randomized=True, slope=slope)
  consist = consist_loss(out, cfg.joint.target)
  if out["rgb_ray"] is None:
    return consist, None
  # out["rgb"] carries no gradient: the radiance field is frozen above
  return consist, losses.reconstruction(out["rgb_ray"], out["rgb"])


def two_plane_rays(uv, st) -> Rays:
  """Rays uv, st [R, 2] in the renderers' form: (u, v, 0) and (s, t, 1)."""
  return Rays(jnp.pad(uv, ((0, 0), (0, 1))), jnp.pad(st, ((0, 0), (0, 1)), constant_values=1.0))


def camera_box(pixels):
  """The box of the training rays' (u, v, s, t), [2 (min, max), 4] (numpy),
  where the random rays of L_consist are drawn: (u, v) between the
  training cameras, (s, t) over the training pixels' extent (the pixel
  centres, inside [-1, 1] on a grid's image plane)."""
  uvst = np.concatenate([pixels.rays.origins[:, :2], pixels.rays.dirs[:, :2]], -1)
  return np.stack([uvst.min(0), uvst.max(0)])


def make_eval_fn(model, ray_model, cfg, theta_n, theta_f, block_rays=0, slope="angle"):
  """Jitted ((params, alpha), origins, dirs) -> raycast.eval_outputs (depth:
  expected tau), rays as LightFieldViews.rays() gives them (raycast.jit_eval)."""
  def render_final(state, rays):
    params, alpha = state
    return render_rays(model, ray_model, cfg, params, rays, jax.random.PRNGKey(0), alpha,
                       theta_n=theta_n, theta_f=theta_f, randomized=False, slope=slope)
  return raycast.jit_eval(render_final, block_rays)


def train(ctx: base.StageContext):
  """Trains the light-field stage ctx.name; returns (StageState, info)."""
  config, name, dataset, cfg = ctx.config, ctx.name, ctx.dataset, ctx.cfg
  microbatch.check_parts(cfg, cfg.batch_rays, f"{name}.batch_rays", ctx.mesh)
  if _sampler(cfg).trains_guide and cfg.joint.random_rays > 0:
    microbatch.check_parts(cfg, cfg.joint.random_rays, f"{name}.joint.random_rays", ctx.mesh)
  model, ray_model = models_from_config(config, name)
  theta_n, theta_f = dataset.near, dataset.far
  data = jax.device_put(terms.stage_data(ctx, cfg, batches.pixels_of(dataset.train, None),
                                         terms.active_terms(cfg)))
  step_loss = functools.partial(loss_fn, model=model, ray_model=ray_model, cfg=cfg,
                                theta_n=theta_n, theta_f=theta_f, mesh=ctx.mesh,
                                slope=dataset.epi_slope)
  render_eval = make_eval_fn(model, ray_model, cfg, theta_n, theta_f, config.eval.block_rays,
                             dataset.epi_slope)

  def eval_fn(params, step):
    # the joint sampler renders with the window it trains with at this step
    fn = functools.partial(render_eval, (params, joint_window(cfg, step)))
    return evaluate.heldout(fn, dataset.test, config.eval.chunk, config.eval.curve_views)

  params, step, info = loop.train(name, cfg, ctx.workdir,
                                  init_params(model, ray_model, config.seed), step_loss,
                                  data, config.seed, eval_fn, ctx.log, ctx.wall_offset, ctx.mesh,
                                  snapshot_s=ctx.front_s, pacer=ctx.pacer,
                                  baseline=collapse.pixels_baseline(dataset.train.images),
                                  select_fn=base.select_fn(
                                      ctx, lambda p, s: functools.partial(
                                          render_eval, (p, joint_window(cfg, s)))))
  at = info.get("selected", {}).get("step", step)
  final = functools.partial(render_eval, (params, joint_window(cfg, at)))
  info["eval"] = evaluate.evaluate(final, dataset.test, config.eval.chunk,
                                   os.path.join(stage_dir(ctx.workdir, name), "eval"), 0.0, 1.0,
                                   config.eval.save_images, config.eval.lpips,
                                   desc=f"{name} eval")
  return StageState(params, step, config, name), info


def params_like(config, name, dataset=None):
  model, ray_model = models_from_config(config, name)
  return init_params(model, ray_model, config.seed)


def renderer(config, name, dataset, states):
  """The finished stage states[name] as a render fn of (o, d), as its final
  evaluation rendered (the joint window at its last step)."""
  model, ray_model = models_from_config(config, name)
  cfg, state = config[name], states[name]
  render_eval = make_eval_fn(model, ray_model, cfg, dataset.near, dataset.far,
                             config.eval.block_rays, dataset.epi_slope)
  return functools.partial(render_eval, (state.params, joint_window(cfg, int(state.step))))


base.TRAINERS.register("light_field", base.Trainer(
    requires=requires, params_like=params_like, train=train, check=check,
    geometries=frozenset({geometry.Geometry.TWO_PLANE}), renderer=renderer))
