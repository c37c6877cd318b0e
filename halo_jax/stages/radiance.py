"""The radiance-field stage: Lo-NeRF, Hi-NeRF and the NeRF baselines.

One trainer, configured by data: the stage's model (models.MODELS), sampler
(samplers.SAMPLERS) and loss terms (stages.terms.TERMS). Lo-NeRF is a
low-frequency field with stratified samples; Hi-NeRF reads the frozen ray
field's depth (depth_guided) and L_empty against the frozen Lo-NeRF; the
baselines are the Hi stage with other samplers and terms.
"""
import dataclasses
import functools
import os
import time
from typing import Any

import jax
import ml_collections

from halo_jax import evaluate, geometry, lightfield, models, parallel, ray_fields, raycast
from halo_jax import registry, sampler_switch, samplers
from halo_jax.rays import Batch
from halo_jax.stages import base, batches, budget, collapse, loop, microbatch, terms
from halo_jax.stages.state import StageState, stage_dir
from halo_jax.stages.transfer import transfer_from_lo
from halo_jax.types import Config

SEED_COARSE = 7  # offset of the coarse MLP's init seed from config.seed


def _sampler(cfg):
  return samplers.SAMPLERS.get(cfg.sampler.kind, "sampler.kind")


def requires(config, name):
  """Finished stages this stage reads: its sampler's, its terms', Lo-NeRF
  for init_from_lo."""
  cfg = config[name]
  needs = set(samplers.SAMPLERS.get(cfg.sampler.kind, f"{name}.sampler.kind").needs)
  for _, term in terms.active_terms(cfg):
    needs.update(term.needs(cfg))
  if cfg.init_from_lo:
    needs.add("lo")
  return tuple(sorted(needs))


def check(config, name, dspec):
  """ConfigError for a model, sampler or term the scene kind cannot take."""
  cfg = config[name]
  kind = cfg.model.kind
  mspec = models.MODELS.get(kind, f"{name}.model.kind")
  where = f"data.kind={config.data.kind!r} ({dspec.geometry.value} rays"
  where += ", frames with times)" if dspec.dynamic else ")"
  registry.check(dspec.geometry in mspec.geometries,
                 f"{name}.model.kind={kind!r} takes {geometry.names(mspec.geometries)} rays, "
                 f"not {where}")
  registry.check(mspec.dynamic == dspec.dynamic,
                 f"{name}.model.kind={kind!r} is {'dynamic' if mspec.dynamic else 'static'} but "
                 f"{where}: use 'deform' for scenes with times and 'nerf' for static ones")
  spec = _sampler(cfg)
  registry.check(dspec.geometry in spec.geometries,
                 f"{name}.sampler.kind={cfg.sampler.kind!r} takes "
                 f"{geometry.names(spec.geometries)} rays, not {where}")
  registry.check(spec.dynamic or not dspec.dynamic,
                 f"{name}.sampler.kind={cfg.sampler.kind!r} needs a ray field, which has no "
                 f"time input; {where} needs 'stratified' or 'hierarchical'")
  _check_guided(cfg.sampler, spec, name)
  if sampler_switch.switch_step(cfg):  # and as it samples after its switch
    after = sampler_switch.stage_after(cfg)
    _check_guided(after.sampler, _sampler(after), name)
  terms.check_geometries(cfg, name, dspec, where)
  registry.check(name != "lo" or not (cfg.init_from_lo or cfg.encoding.with_lo),
                 "lo.init_from_lo and lo.encoding.with_lo start a stage from Lo-NeRF; "
                 "Lo-NeRF itself takes False")


def _check_guided(sc, spec, name):
  """ConfigError for a guided sampler's option on a sampler that would ignore
  it, or a share of full-range samples that leaves the window none."""
  full, win_steps = sc.get("num_full", 0), sc.get("window_steps", 0)
  own_edges = spec.guided and spec.guided_edges is None
  registry.check(full == 0 or own_edges,
                 f"{name}.sampler.num_full={full}: only the depth-guided samplers take "
                 f"full-range samples (sampler.kind={sc.kind!r})")
  n = sc.num_coarse if spec.importance else sc.num_samples
  registry.check(0 <= full <= n - 2,
                 f"{name}.sampler.num_full={full}: must leave at least one of the {n} samples "
                 "in the window (0 <= num_full <= samples - 2)")
  registry.check(win_steps == 0 or (own_edges and not spec.trains_guide),
                 f"{name}.sampler.window_steps={win_steps}: only the depth-guided samplers "
                 f"narrow their window over steps (sampler.kind={sc.kind!r})")
  registry.check(win_steps >= 0 and (win_steps == 0 or 0 < sc.window_start <= 1),
                 f"{name}.sampler.window_start={sc.get('window_start', 0.0)!r} with "
                 f"window_steps={win_steps}: the starting half window must be in (0, 1]")


def init_params(config, name, dataset):
  """{'nerf': radiance field[, 'coarse': the first pass's own field][, 'ray':
  the ray field a joint sampler trains]}."""
  cfg = config[name]
  model = models.nerf_from_config(config, name)
  kind = cfg.model.kind
  params = {"nerf": models.init_nerf(model, kind, config.seed)}
  spec = _sampler(cfg)
  if cfg.sampler.get("coarse_model", False):
    params["coarse"] = models.init_nerf(model, kind, config.seed + SEED_COARSE)
  if spec.trains_guide:
    ray_model = ray_fields.ray_field_from_config(config.ray, dataset.near, dataset.far,
                                                 models.sin_cos_of(config))
    params["ray"] = ray_fields.init_ray_field(ray_model, config.seed)
  return params


def joint_window(cfg, step):
  """The joint sampler's half window at `step` (lightfield.alpha_schedule)."""
  return lightfield.alpha_schedule(step, cfg.joint.alpha_steps, cfg.joint.alpha_final)


def band_fraction(cfg, step):
  """FreeNeRF's mask position at `step` (None when the stage has no
  freq_reg): step / (end * the steps the stage trains), capped at 1. Their
  schedule spans the run's length (reg_end_ratio of it), so under a budget
  or a stop_at_step it spans those steps, not the `steps` cap."""
  if "freq_reg" not in cfg or cfg.freq_reg.end <= 0:
    return None
  return jax.numpy.minimum(step / (cfg.freq_reg.end * budget.last_step(cfg)), 1.0)


def loss_fn(params, data: batches.StageData, key, step, part=None, *, s):
  """The stage's loss on one batch drawn on device (split over `s.mesh`'s
  devices when data-parallel), or on its `part` (microbatch.part_of: every ray
  keeps its own PRNG key). s: the stage's StepSettings (`loss_settings`)."""
  cfg = s.cfg
  k_idx, k_crop, k_ren, k_extra, k_extra_s = jax.random.split(key, 5)
  px = data.pixels
  idx = batches.draw(k_idx, k_crop, step, px.rgb.shape[0], cfg.batch_rays, px.index,
                     cfg.precrop_steps, cfg.one_image, cfg.fg_steps, cfg.fg_fraction)
  keys = microbatch.part_of(jax.random.split(k_ren, cfg.batch_rays), part)
  idx = parallel.shard_batch(microbatch.part_of(idx, part), s.mesh)
  batch = Batch(px.rays.take(idx), px.rgb[idx], idx)
  guide, window = _guide_at(s, params, data, step)
  outs = raycast.render_rays(
      s.model, cfg.sampler, params["nerf"], batch.rays.origins, batch.rays.dirs, keys,
      near=s.near, far=s.far, white_background=s.white, randomized=True,
      noise=cfg.density_noise, guide=guide, times=batch.rays.times, window=window,
      coarse_params=params.get("coarse"), band_fraction=band_fraction(cfg, step))
  x = terms.Inputs(params, s.model, outs, batch, data, (k_extra, k_extra_s), part,
                   s.mesh, s.near, s.far, s.white, guide)
  loss, aux = terms.total(cfg, step, x, s.terms)
  if window is not None:
    aux["alpha"] = window
  return loss, aux


def _guide_at(s, params, data, step):
  """(Guide or None, the guided window at this step or None: the sampler's
  own `window`)."""
  spec = s.sampler
  if not spec.guided:
    return None, None
  if spec.trains_guide:
    return (raycast.Guide(s.guide_model, params["ray"], s.geometry, s.radius),
            joint_window(s.cfg, step))
  return (raycast.Guide(s.guide_model, data.guide, s.geometry, s.radius),
          samplers.window_at(s.cfg.sampler, step))


def _guide_setup(ctx: base.StageContext):
  """(ray-field model, its frozen params or None, the sphere radius) of a
  guided sampler; (None, None, 0) otherwise."""
  cfg, ds = ctx.cfg, ctx.dataset
  spec = _sampler(cfg)
  if not spec.guided:
    return None, None, 0.0
  ray_cfg = ctx.config.ray if spec.trains_guide else ctx.states["ray"].config.ray
  model = ray_fields.ray_field_from_config(ray_cfg, ds.near, ds.far,
                                           models.sin_cos_of(ctx.config))
  radius = ray_fields.guide_radius(ray_cfg, ds)
  frozen = None if spec.trains_guide else ctx.states["ray"].params["ray"]
  return model, frozen, radius


def _initial_params(ctx: base.StageContext):
  config, name, cfg = ctx.config, ctx.name, ctx.cfg
  params = init_params(config, name, ctx.dataset)
  if cfg.init_from_lo:
    lo = ctx.states["lo"]
    if cfg.encoding.with_lo and lo.config.lo.encoding.to_dict() != config.lo.encoding.to_dict():
      raise registry.ConfigError(
          f"{name}.encoding.with_lo: this run's lo.encoding {config.lo.encoding.to_dict()} "
          f"differs from the finished Lo stage's {lo.config.lo.encoding.to_dict()}")
    params["nerf"] = transfer_from_lo(params["nerf"], lo.params["nerf"], cfg.encoding.with_lo,
                                      fresh_skips=(tuple(cfg.model.skips)
                                                   if cfg.get("init_skip_fresh", False) else ()))
  return params


@dataclasses.dataclass(frozen=True)
class StepSettings:
  """What a radiance stage's step reads besides its arrays, built once per
  stage (`loss_settings`): the stage config, the field, the sampler's spec,
  the guide's model and sphere (guided samplers), the ray bounds, the active
  loss terms and the data-parallel mesh."""
  cfg: Config
  model: Any              # the stage's Flax field
  sampler: samplers.SamplerSpec
  guide_model: Any        # the guide's Flax ray field, or None
  geometry: geometry.Geometry
  radius: float
  near: float
  far: float
  white: bool
  terms: tuple
  mesh: Any               # a jax.sharding.Mesh or None


def loss_settings(cfg, model, *, near, far, white, geometry_=geometry.Geometry.SPHERE,
                  radius=0.0, guide_model=None, mesh=None) -> StepSettings:
  """The static settings `loss_fn` reads (its `s`)."""
  return StepSettings(cfg=cfg, model=model, sampler=_sampler(cfg), guide_model=guide_model,
                      geometry=geometry_, radius=radius, near=near, far=far, white=white,
                      terms=terms.active_terms(cfg), mesh=mesh)


def _stage_settings(ctx: base.StageContext, cfg):
  """(StepSettings of stage ctx.name run with `cfg`, the frozen guide's
  params or None)."""
  ds = ctx.dataset
  guide_model, guide_params, radius = _guide_setup(ctx)
  settings = loss_settings(cfg, models.nerf_from_config(ctx.config, ctx.name), near=ds.near,
                           far=ds.far, white=ds.white_background, geometry_=ds.geometry,
                           radius=radius, guide_model=guide_model, mesh=ctx.mesh)
  return settings, guide_params


def _eval_closures(ctx, s: StepSettings, guide_params):
  """(make_eval(params, step) -> render fn of (o, d[, t]), eval_fn for curves)."""
  config, ds, cfg = ctx.config, ctx.dataset, s.cfg
  render_eval = raycast.make_eval_fn(
      s.model, cfg.sampler, near=s.near, far=s.far, white_background=s.white,
      guide_model=s.guide_model, geometry=s.geometry, radius=s.radius,
      block_rays=config.eval.block_rays)
  trains_guide = s.sampler.trains_guide
  render_switched = None
  if sampler_switch.switch_step(cfg):  # a field past its switch is scored as it trains
    render_switched = raycast.make_eval_fn(
        s.model, sampler_switch.stage_after(cfg).sampler, near=s.near, far=s.far,
        white_background=s.white, guide_model=s.guide_model, geometry=s.geometry,
        radius=s.radius, block_rays=config.eval.block_rays)
  after = cfg.sampler.get("dense_eval_after", 0)
  render_dense = None
  if after:
    dense = ml_collections.ConfigDict(cfg.sampler.to_dict())
    dense.update(kind="stratified", num_samples=cfg.sampler.dense_eval_samples)
    render_dense = raycast.make_eval_fn(
        s.model, dense, near=s.near, far=s.far, white_background=s.white, geometry=s.geometry,
        radius=s.radius, block_rays=config.eval.block_rays)

  def make_eval(p, step):
    step = cfg.steps if step is None else step
    kw = dict(coarse_params=p.get("coarse"), band_fraction=band_fraction(cfg, step))
    if render_dense is not None and min(step, budget.last_step(cfg)) >= after:
      # a field trained this long has moved off the window its guide places:
      # its held-out views are rendered densely over the whole ray
      return functools.partial(render_dense, p["nerf"], None, **kw)
    render = render_eval
    if render_switched is not None and sampler_switch.after(cfg, min(step, budget.last_step(cfg))):
      render = render_switched
    if trains_guide:  # the window the joint sampler trains with at this step
      return functools.partial(render, p["nerf"], p["ray"], window=joint_window(cfg, step), **kw)
    return functools.partial(render, p["nerf"], guide_params,
                             window=samplers.window_at(cfg.sampler, step), **kw)

  def eval_fn(params, step=None):
    return evaluate.heldout(make_eval(params, step), ds.test, config.eval.chunk,
                           config.eval.curve_views)
  return make_eval, eval_fn


def train(ctx: base.StageContext):
  """Trains the radiance-field stage ctx.name; returns (StageState, info)."""
  config, name, ds = ctx.config, ctx.name, ctx.dataset
  cfg = ctx.cfg
  active = terms.active_terms(cfg)
  microbatch.check_parts(cfg, cfg.batch_rays, f"{name}.batch_rays", ctx.mesh)
  if any(n == "empty" for n, _ in active):
    microbatch.check_parts(cfg, cfg.empty.num_rays, f"{name}.empty.num_rays", ctx.mesh)
  if any(n == "unseen" for n, _ in active):
    microbatch.check_parts(cfg, cfg.unseen.num_points, f"{name}.unseen.num_points", ctx.mesh)
  if any(n == "teach" for n, _ in active):
    microbatch.check_parts(cfg, cfg.teach.num_rays, f"{name}.teach.num_rays", ctx.mesh)
  params = _initial_params(ctx)
  t0 = time.perf_counter()
  settings, guide_params = _stage_settings(ctx, cfg)
  registry.check(cfg.fg_steps <= 0 or ds.white_background,
                 f"{name}.fg_steps={cfg.fg_steps}: drawing from the foreground needs a scene "
                 "on a white background; set it to 0")
  background = 1.0 if cfg.fg_steps > 0 else None
  pixels = batches.pixels_of(ds.train, cfg.precrop_frac, background)
  data = jax.device_put(terms.stage_data(ctx, cfg, pixels, active, guide_params))
  bank_s = time.perf_counter() - t0  # rendering Lo targets counts as training time
  cfg = budget.minus_seconds(cfg, bank_s)
  settings = dataclasses.replace(settings, cfg=cfg)
  make_eval, eval_fn = _eval_closures(ctx, settings, guide_params)
  step_loss = functools.partial(loss_fn, s=settings)
  switch = None
  if sampler_switch.switch_step(cfg):  # the steps past it sample as sampler_switch.py says
    after_cfg = sampler_switch.stage_after(cfg)
    switch = (sampler_switch.switch_step(cfg), functools.partial(
        loss_fn, s=dataclasses.replace(settings, cfg=after_cfg, sampler=_sampler(after_cfg))))
  params, step, info = loop.train(name, cfg, ctx.workdir, params, step_loss, data, config.seed,
                                  eval_fn, ctx.log, ctx.wall_offset + bank_s, ctx.mesh,
                                  snapshot_s=ctx.front_s, pacer=ctx.pacer,
                                  baseline=collapse.pixels_baseline(ds.train.images),
                                  select_fn=base.select_fn(ctx, make_eval), switch=switch)
  info["wall_s"] += bank_s
  info["setup_s"] = bank_s
  eval_dir = os.path.join(stage_dir(ctx.workdir, name), "eval")
  final = make_eval(params, info.get("selected", {}).get("step", step))
  info["eval"] = evaluate.evaluate(final, ds.test, config.eval.chunk, eval_dir, ds.near, ds.far,
                                   config.eval.save_images, config.eval.lpips,
                                   desc=f"{name} eval")
  if ds.dynamic:
    info["eval"]["flicker"] = evaluate.flicker(
        final, ds.test, config.eval.chunk, config.eval.flicker_frames,
        eval_dir if config.eval.save_images else None)
  return StageState(params, step, config, name), info


def renderer(config, name, dataset, states):
  """The finished stage states[name] as a render fn of (o, d[, t]), exactly as
  its final evaluation rendered (same sampler, guide and step-dependent terms)."""
  ctx = base.StageContext(config, name, dataset, "", states)
  settings, guide_params = _stage_settings(ctx, config[name])
  make_eval, _ = _eval_closures(ctx, settings, guide_params)
  return make_eval(states[name].params, int(states[name].step))


def guide(config, name, dataset, states):
  """(the raycast.Guide that places states[name]'s samples, its sampler
  config), or None for a sampler no ray field guides."""
  ctx = base.StageContext(config, name, dataset, "", states)
  settings, guide_params = _stage_settings(ctx, config[name])
  if not settings.sampler.guided:
    return None
  params = states[name].params["ray"] if settings.sampler.trains_guide else guide_params
  return (raycast.Guide(settings.guide_model, params, settings.geometry, settings.radius),
          config[name].sampler)


base.TRAINERS.register("radiance", base.Trainer(
    requires=requires, params_like=init_params, train=train, check=check,
    geometries=geometry.SPATIAL, renderer=renderer, guide=guide))
