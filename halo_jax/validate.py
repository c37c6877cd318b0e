"""`validate(config)`: every check that needs no data, run before any work.

Each failure is one ConfigError line that names the field(s) and what is
allowed. The checks are generators of those lines, read in order up to the
first (a later check may assume that an earlier one passed); the stage graph
is read once (stages/order.py) and handed to the checks that need it.
Checks that depend on the scene kind use the dataset registry's declaration
(its ray geometry, whether frames carry times), not the data.
"""
import math

from halo_jax import datasets, geometry, models, protocol, samplers, trig
from halo_jax.frequency import view_pairs
from halo_jax.registry import ConfigError
from halo_jax.stages import base, order

TRAIN_FIELDS = ("steps", "batch_rays", "lr_init", "lr_final", "microbatches")


def _positive_int(value, field):
  if not (isinstance(value, int) and not isinstance(value, bool) and value > 0):
    yield f"{field}={value!r}: must be a positive integer"


def _positive_float(value, field):
  if not (isinstance(value, (int, float)) and not isinstance(value, bool)
          and math.isfinite(value) and value > 0):
    yield f"{field}={value!r}: must be a positive number"


def _training(cfg, name):
  yield from _positive_int(cfg.steps, f"{name}.steps")
  yield from _positive_int(cfg.batch_rays, f"{name}.batch_rays")
  yield from _positive_float(cfg.lr_init, f"{name}.lr_init")
  yield from _positive_float(cfg.lr_final, f"{name}.lr_final")
  yield from _positive_int(cfg.microbatches, f"{name}.microbatches")
  if cfg.batch_rays % cfg.microbatches:
    yield (f"{name}.microbatches={cfg.microbatches} does not divide "
           f"{name}.batch_rays={cfg.batch_rays}")
  for field in ("checkpoint_every", "log_every"):
    yield from _positive_int(cfg[field], f"{name}.{field}")
  if not (isinstance(cfg.max_nonfinite, int) and cfg.max_nonfinite >= 0):
    yield f"{name}.max_nonfinite={cfg.max_nonfinite!r}: must be an integer >= 0"
  if not cfg.max_seconds >= 0:
    yield f"{name}.max_seconds={cfg.max_seconds!r}: must be >= 0"
  for field in ("min_steps", "target_rays", "stop_at_step"):
    if field in cfg and not (isinstance(cfg[field], int) and cfg[field] >= 0):
      yield f"{name}.{field}={cfg[field]!r}: must be an integer >= 0"


def _selection(config, name):
  cfg = config[name]
  if not cfg.get("select_best", False):
    return
  if not config.data.get("select_views"):
    yield (f"{name}.select_best=True needs data.select_views: the views that choose the "
           "parameters (never the test views)")
  if not (cfg.eval_every or cfg.eval_every_s):
    yield (f"{name}.select_best=True scores the parameters at the held-out evaluations: set "
           f"{name}.eval_every or {name}.eval_every_s")


def _sampler(cfg, name):
  if "sampler" not in cfg:
    return
  s = cfg.sampler
  spec = samplers.SAMPLERS.get(s.kind, f"{name}.sampler.kind")
  yield from _positive_int(s.num_samples, f"{name}.sampler.num_samples")
  if spec.importance:
    yield from _positive_int(s.num_coarse, f"{name}.sampler.num_coarse")
  if spec.guided and not 0 < s.window <= 1:
    yield f"{name}.sampler.window={s.window!r}: must be in (0, 1]"
  after = s.get("dense_eval_after", 0)
  if not (isinstance(after, int) and after >= 0):
    yield f"{name}.sampler.dense_eval_after={after!r}: must be an integer >= 0 (0: never)"
  elif after:
    yield from _positive_int(s.dense_eval_samples, f"{name}.sampler.dense_eval_samples")
  yield from _switch(cfg, name)


def _switch(cfg, name):
  """The sampler switch's fields (sampler_switch.py): a radiance stage's,
  to a sampler of the same guide."""
  s = cfg.sampler
  step = s.get("switch_step", 0)
  if not step:
    return
  if not (isinstance(step, int) and not isinstance(step, bool) and step > 0):
    yield f"{name}.sampler.switch_step={step!r}: must be an integer >= 0 (0: never)"
    return
  if cfg.get("kind") != "radiance":
    yield (f"{name}.sampler.switch_step={step}: only a radiance-field stage switches its "
           f"sampler ({name}.kind={cfg.get('kind')!r})")
    return
  yield from _positive_int(s.switch_samples, f"{name}.sampler.switch_samples")
  if s.switch_kind:
    mine = samplers.SAMPLERS.get(s.kind, f"{name}.sampler.kind")
    theirs = samplers.SAMPLERS.get(s.switch_kind, f"{name}.sampler.switch_kind")
    same = ("guided", "trains_guide", "needs", "geometries", "dynamic")
    if any(getattr(mine, f) != getattr(theirs, f) for f in same):
      yield (f"{name}.sampler.switch_kind={s.switch_kind!r}: switches from {s.kind!r} to a "
             "sampler that reads another guide or takes other rays; it must place samples "
             f"from what {s.kind!r} reads")


def _model(cfg, name):
  if "model" not in cfg or "compute_dtype" not in cfg.model:
    return
  if cfg.model.compute_dtype not in models.COMPUTE_DTYPES:
    yield (f"{name}.model.compute_dtype={cfg.model.compute_dtype!r}: must be one of "
           f"{sorted(models.COMPUTE_DTYPES)}")


def _front(config):
  times = tuple(config.eval.front_s)
  for t in times:
    yield from _positive_float(t, "eval.front_s")
  if list(times) != sorted(set(times)):
    yield f"eval.front_s={times!r}: training seconds must increase"


def _auto(config, graph, dspec):
  if not config.lo.encoding.auto:
    return
  if "lo" not in graph.final or config.lo.kind != "radiance":
    yield (f"lo.encoding.auto=True: the frequency rule picks Lo-NeRF's P.E., and this config's "
           f"output stage {config.final_stage!r} needs no Lo-NeRF radiance stage (data.kind="
           f"{config.data.kind!r}); set the frequencies by hand")
  if dspec.facts.pair_kind not in view_pairs.PAIR_KINDS:
    yield (f"lo.encoding.auto=True: data.kind={config.data.kind!r} declares no view pairs "
           f"for the frequency rule (pair kind {dspec.facts.pair_kind!r}); set "
           "lo.encoding.L and lo.encoding.scale by hand")


def _problems(config, graph, dspec):
  """The scene's fields, every stage section's kind, sampler and model, each
  stage the run needs (the requested stage's own complaint first), then the
  front, the run-wide fields and the protocol."""
  if config.data.kind == "procedural":
    scenes = sorted(datasets.procedural.SCENES)
    if config.data.procedural_scene not in scenes:
      yield (f"data.procedural_scene={config.data.get('procedural_scene')!r}: must be one "
             f"of {scenes}")
  for name in graph.sections:
    base.trainer_of(config, name)
    yield from _sampler(config[name], name)
    yield from _model(config[name], name)
  for name in reversed(graph.every):
    trainer = base.trainer_of(config, name)
    if dspec.geometry not in trainer.geometries:
      yield (f"{name}.kind={config[name].kind!r} trains on "
             f"{geometry.names(trainer.geometries)} rays; data.kind={config.data.kind!r} has "
             f"{dspec.geometry.value} rays")
    yield from _training(config[name], name)
    yield from _selection(config, name)
    trainer.check(config, name, dspec)
  yield from _front(config)
  if config.get("sin_cos") not in trig.KINDS:
    yield f"sin_cos={config.get('sin_cos')!r}: must be one of {list(trig.KINDS)}"
  yield from _auto(config, graph, dspec)
  yield from protocol.problems(config, graph)


def validate(config) -> order.Graph:
  """Raises ConfigError (one line naming the field) for a config that cannot
  run; returns its stage graph for one that can."""
  graph = order.graph(config)  # names an unknown stage, kind or sampler first
  dspec = datasets.spec_of(config.data)
  for message in _problems(config, graph, dspec):
    raise ConfigError(message)
  return graph


__all__ = ["ConfigError", "validate"]
