"""`validate(config)`: every check that needs no data, run before any work.

Each failure is one ConfigError line that names the field(s) and what is
allowed. Checks that depend on the scene kind use the dataset registry's
declaration (its ray geometry, whether frames carry times), not the data.
"""
import math

from halo_jax import datasets, geometry, models, protocol, samplers, trig
from halo_jax.frequency import view_pairs
from halo_jax.registry import ConfigError, check
from halo_jax.stages import base, order

TRAIN_FIELDS = ("steps", "batch_rays", "lr_init", "lr_final", "microbatches")


def _positive_int(value, field):
  check(isinstance(value, int) and not isinstance(value, bool) and value > 0,
        f"{field}={value!r}: must be a positive integer")


def _positive_float(value, field):
  check(isinstance(value, (int, float)) and not isinstance(value, bool)
        and math.isfinite(value) and value > 0, f"{field}={value!r}: must be a positive number")


def _check_training(cfg, name):
  _positive_int(cfg.steps, f"{name}.steps")
  _positive_int(cfg.batch_rays, f"{name}.batch_rays")
  _positive_float(cfg.lr_init, f"{name}.lr_init")
  _positive_float(cfg.lr_final, f"{name}.lr_final")
  _positive_int(cfg.microbatches, f"{name}.microbatches")
  check(cfg.batch_rays % cfg.microbatches == 0,
        f"{name}.microbatches={cfg.microbatches} does not divide "
        f"{name}.batch_rays={cfg.batch_rays}")
  for field in ("checkpoint_every", "log_every"):
    _positive_int(cfg[field], f"{name}.{field}")
  check(isinstance(cfg.max_nonfinite, int) and cfg.max_nonfinite >= 0,
        f"{name}.max_nonfinite={cfg.max_nonfinite!r}: must be an integer >= 0")
  check(cfg.max_seconds >= 0, f"{name}.max_seconds={cfg.max_seconds!r}: must be >= 0")
  for field in ("min_steps", "target_rays", "stop_at_step"):
    if field in cfg:
      check(isinstance(cfg[field], int) and cfg[field] >= 0,
            f"{name}.{field}={cfg[field]!r}: must be an integer >= 0")


def _check_selection(config, name):
  cfg = config[name]
  if not cfg.get("select_best", False):
    return
  check(bool(config.data.get("select_views")),
        f"{name}.select_best=True needs data.select_views: the views that choose the "
        "parameters (never the test views)")
  check(bool(cfg.eval_every or cfg.eval_every_s),
        f"{name}.select_best=True scores the parameters at the held-out evaluations: set "
        f"{name}.eval_every or {name}.eval_every_s")


def _check_sampler(cfg, name):
  if "sampler" not in cfg:
    return
  s = cfg.sampler
  spec = samplers.SAMPLERS.get(s.kind, f"{name}.sampler.kind")
  _positive_int(s.num_samples, f"{name}.sampler.num_samples")
  if spec.importance:
    _positive_int(s.num_coarse, f"{name}.sampler.num_coarse")
  if spec.guided:
    check(0 < s.window <= 1, f"{name}.sampler.window={s.window!r}: must be in (0, 1]")


def _check_model(cfg, name):
  if "model" not in cfg or "compute_dtype" not in cfg.model:
    return
  dtypes = sorted(models.COMPUTE_DTYPES)
  check(cfg.model.compute_dtype in models.COMPUTE_DTYPES,
        f"{name}.model.compute_dtype={cfg.model.compute_dtype!r}: must be one of {dtypes}")


def _check_budget(config, names):
  del names  # the protocol's own check reads the stages the run needs
  protocol.check(config)


def _check_front(config):
  times = tuple(config.eval.front_s)
  for t in times:
    _positive_float(t, "eval.front_s")
  check(list(times) == sorted(set(times)),
        f"eval.front_s={times!r}: training seconds must increase")


def _check_auto(config, dspec):
  if not config.lo.encoding.auto:
    return
  final = config.final_stage
  check("lo" in order.needed(config, final) and config.lo.kind == "radiance",
        f"lo.encoding.auto=True: the frequency rule picks Lo-NeRF's P.E., and this config's "
        f"output stage {final!r} needs no Lo-NeRF radiance stage (data.kind="
        f"{config.data.kind!r}); set the frequencies by hand")
  check(dspec.facts.pair_kind in view_pairs.PAIR_KINDS,
        f"lo.encoding.auto=True: data.kind={config.data.kind!r} declares no view pairs "
        f"for the frequency rule (pair kind {dspec.facts.pair_kind!r}); set "
        "lo.encoding.L and lo.encoding.scale by hand")


def validate(config) -> None:
  """Raises ConfigError (one line naming the field) for a config that cannot
  run; returns None for one that can."""
  dspec = datasets.spec_of(config.data)
  if config.data.kind == "procedural":
    scenes = sorted(datasets.procedural.SCENES)
    check(config.data.procedural_scene in scenes,
          f"data.procedural_scene={config.data.get('procedural_scene')!r}: must be one of {scenes}")
  for name in order.stage_names(config):  # names the field before the graph reads it
    base.trainer_of(config, name)
    _check_sampler(config[name], name)
    _check_model(config[name], name)
  names = order.needed(config)
  final = config.final_stage
  check(final in order.stage_names(config),
        f"final_stage={final!r}: must be one of {list(order.stage_names(config))}")
  every = tuple(dict.fromkeys(names + order.needed(config, final)))
  for name in reversed(every):  # the requested stage's own complaint first
    trainer = base.trainer_of(config, name)
    check(dspec.geometry in trainer.geometries,
          f"{name}.kind={config[name].kind!r} trains on {geometry.names(trainer.geometries)} "
          f"rays; data.kind={config.data.kind!r} has {dspec.geometry.value} rays")
    _check_training(config[name], name)
    _check_selection(config, name)
    trainer.check(config, name, dspec)
  _check_budget(config, order.needed(config, final))
  _check_front(config)
  check(config.get("sin_cos") in trig.KINDS,
        f"sin_cos={config.get('sin_cos')!r}: must be one of {list(trig.KINDS)}")
  _check_auto(config, dspec)


__all__ = ["ConfigError", "validate"]
