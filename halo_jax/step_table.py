"""The committed table of step times behind the 'budget' protocol
(halo_jax/protocol.py): seconds per training step and seconds of set-up work
(rendering Lo-NeRF's targets or banks) of each stage, measured on one
reference machine by `python -m experiments.step_times` (experiments/bench/step_times.py).

An entry's key is what sets a step's time, not a scene's name:

  <method>|<data.kind>[+<data.rays>]|<stage>|<digest>

where the digest hashes the stage's sizes: its section of the config without
the fields that change what a step computes but not how long it takes
(rates, schedules, caps, logging, weights' values; a term's being on or off
stays in). A new scene of a known kind and size (chair beside lego) finds
lego's entry; a change of batch, samples, width or sampler makes a new key,
which `python -m experiments.step_times` measures (until then, runs of it measure themselves).
A stage's steps after its sampler switch are priced by a key of their own
(`after_switch_key`).
The ray field's set-up renders Lo-NeRF's targets for every training pixel up
to `target_rays`, so its key also holds the number of training views.
"""
import functools
import hashlib
import json
import os

from halo_jax import config_files, sampler_switch

TABLE = os.path.join(os.path.dirname(__file__), "step_table.json")

# Stage fields that do not change a step's time (dotted, under the stage).
TIMELESS = frozenset((
    "steps", "stop_at_step", "min_steps", "max_seconds", "max_nonfinite", "budget_steps",
    "ref_step_s", "ref_setup_s", "ref_offset_s", "lr_init", "lr_final", "lr_power",
    "lr_decay_steps", "checkpoint_every", "log_every", "eval_every", "eval_every_s", "select_best",
    "precrop_steps", "precrop_frac", "fg_steps", "fg_fraction", "density_noise", "init_from_lo",
    "copy_lo_under_budget",
    "init_skip_fresh", "encoding.scale", "encoding.time_scale", "encoding.auto",
    "model.density_bias", "empty.tau", "empty.start_step", "empty.density_noise",
    "freq_reg.end", "joint.alpha_final", "joint.alpha_steps", "joint.seed", "fourier.seed",
    "fourier.st_std", "fourier.theta_std", "fourier.uv_std", "joint.std", "joint.uv_std",
    "sampler.window", "sampler.window_start", "sampler.window_steps", "sampler.num_full",
    "sampler.coarse_weight", "sampler.dense_eval_after", "sampler.dense_eval_samples",
    # the steps after a sampler switch have a key of their own (after_switch_key)
    "sampler.switch_step", "sampler.switch_samples", "sampler.switch_kind",
    "ref_switch_step", "ref_after_step_s",
    "collapse.margin_db", "collapse.after_steps",
    "collapse.window", "radius", "tau", "schedule_span", "acc_weight", "random_acc"))
# Weights: only whether the term is on sets the time.
WEIGHTS = ("weight", "consist_weight", "color_weight", "nerf_consist_weight")
# Term sections added after the table's keys were measured: they count only
# while their term is on, so a stage without the term keeps its key.
LATER_TERMS = ("teach",)


def _sizes(config, name) -> dict:
  """The stage's fields that set its step time, dotted."""
  out = {}
  off = {t for t in LATER_TERMS if t in config[name] and not config[name][t].weight}
  stage = config[name].to_dict()
  if "plan" in config and name in config.plan:  # the stage as it trains (protocol.effective)
    stage = config_files.laid_over(stage, config.plan[name].to_dict())
  for field, value in config_files.dotted_fields(stage).items():
    if field in TIMELESS or field.split(".", 1)[0] in off:
      continue
    if field.rsplit(".", 1)[-1] in WEIGHTS:
      value = bool(value)
    out[field] = list(value) if isinstance(value, tuple) else value
  out["sin_cos"] = config.get("sin_cos", "xla")
  out["data_parallel"] = bool(config.parallel.data_parallel)
  if config[name].kind == "ray_field":
    views = str(config.data.train_views)
    out["train_views"] = len(views.split(",")) if "," in views else views
  return out


def key(config, name) -> str:
  """The table key of stage `name` of a method's config (resolved, its plan
  laid over the stage, or as the stages train it)."""
  digest = hashlib.sha256(json.dumps(_sizes(config, name), sort_keys=True,
                                     default=str).encode()).hexdigest()[:12]
  rays = config.data.get("rays", "")
  return f"{config.method}|{config.data.kind}{'+' + rays if rays else ''}|{name}|{digest}"


def after_switch_key(config, name) -> str:
  """The table key of stage `name`'s steps after its sampler switch
  (sampler_switch.py): the key of the stage sampling so from its first step."""
  return key(sampler_switch.switched(config, name), name)


@functools.lru_cache(maxsize=8)
def _read(path: str) -> dict:
  if not os.path.exists(path):
    return {}
  with open(path) as f:
    return json.load(f)


def load(path: str = "") -> dict:
  """{key: {'step_s', 'setup_s', ...}} of the table at `path` ('' : the shipped one)."""
  return dict(_read(path or TABLE).get("entries", {}))


def machine(path: str = "") -> dict:
  """The reference machine the table was measured on (its 'machine' record)."""
  return dict(_read(path or TABLE).get("machine", {}))

