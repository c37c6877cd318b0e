"""How long a stage's loop runs, in one place: its last step, its reference
clock (`reference_seconds`), and the count a stage with no table entry
fixes after measuring its own steps.

Under every protocol (halo_jax/protocol.py) a stage runs to a step count
known before its loop starts, except a budgeted stage whose sizes the step
table lacks: it has `max_seconds` (its share of the budget, less the set-up
work it did first) and fixes its count after its first MEASURE_STEPS steps
(`fixed_count`); one that passes its sampler switch fixes it again once it
has timed as many steps past the switch. No loop stops on the clock.
"""
import json
import math
import os

from halo_jax import frozen

# steps a self-measuring stage times after compilation before fixing its count
MEASURE_STEPS = 20


def measured_share(config, name, until, spent):
  """The config stage `name` trains with: for a self-measuring stage, a new
  value whose `max_seconds` is what is left of the budget up to it (`until`,
  protocol.shares_until's) after `spent` reference seconds of the stages before it;
  otherwise `config` itself. The run's config is never edited."""
  if config[name].max_seconds and name in until:
    return frozen.replaced(config, {f"{name}.max_seconds": max(until[name] - spent, 1e-3)})
  return config


def reference_seconds(stage, steps, offset=0.0) -> float:
  """`offset` plus the reference seconds of a stage's set-up and its first
  `steps` steps, from its plan's fields (or a stage config holding them):
  the table's step time up to its sampler switch (halo_jax/sampler_switch.py)
  and its after-switch step time past it."""
  switch = stage.get("ref_switch_step", 0)
  if not switch or steps <= switch:
    return offset + stage["ref_setup_s"] + steps * stage["ref_step_s"]
  return (offset + stage["ref_setup_s"] + switch * stage["ref_step_s"]
          + (steps - switch) * stage["ref_after_step_s"])


def minus_seconds(cfg, seconds):
  """A copy of a self-measuring stage's config whose time leaves room for
  `seconds` the stage already spent outside the loop (e.g. rendering Lo-NeRF
  targets); a stage with a fixed count is returned as it is."""
  if not cfg.max_seconds:
    return cfg
  return frozen.replaced(cfg, {"max_seconds": max(cfg.max_seconds - seconds, 1e-3)})


def last_step(cfg) -> int:
  """The step a stage's loop ends at: `steps`, or `stop_at_step` or the
  budget's `budget_steps` where sooner."""
  return min(cfg.steps, cfg.stop_at_step or cfg.steps, cfg.get("budget_steps", 0) or cfg.steps)


def fixed_count(cfg, step_s: float, after_s: float = 0.0, switch: int = 0) -> int:
  """The step count of a self-measuring stage whose steps take `step_s`, and
  `after_s` past its sampler switch `switch` (0.0: not measured yet, or no
  switch): the step that crosses max_seconds is taken, and at least
  min(min_steps, steps), at most last_step."""
  count = math.ceil(cfg.max_seconds / max(step_s, 1e-9) - 1e-9)
  if switch and after_s and count > switch:
    count = switch + math.ceil((cfg.max_seconds - switch * step_s) / after_s - 1e-9)
  return max(1, min(max(count, min(cfg.min_steps, cfg.steps)), last_step(cfg)))


def measured_seconds(step_s: float, after_s: float, switch: int, first: int, last: int) -> float:
  """Seconds of a self-measuring stage's steps first+1 .. last: `step_s` a
  step up to its switch (0: none), `after_s` past it (0.0: not measured
  yet, taken as `step_s`)."""
  if not switch or not after_s:
    return (last - first) * step_s
  before = max(min(last, switch) - min(first, switch), 0)
  return before * step_s + (last - first - before) * after_s


def _fixed_path(workdir, name):
  return os.path.join(workdir, name, "fixed_steps.json")


def read_fixed(workdir, name):
  """{'steps', 'step_s'[, 'after_step_s' or 'after_pending']} a self-measuring
  stage fixed earlier (None if none): a stage that passes its sampler switch
  fixes a count before it (`after_pending`) and again once it has timed its
  steps past it."""
  path = _fixed_path(workdir, name)
  if not os.path.exists(path):
    return None
  with open(path) as f:
    return json.load(f)


def write_fixed(workdir, name, steps: int, step_s: float, after_step_s: float = 0.0,
                after_pending: bool = False):
  os.makedirs(os.path.dirname(_fixed_path(workdir, name)), exist_ok=True)
  out = {"steps": int(steps), "step_s": float(step_s)}
  if after_step_s:
    out["after_step_s"] = float(after_step_s)
  if after_pending:
    out["after_pending"] = True
  with open(_fixed_path(workdir, name), "w") as f:
    json.dump(out, f)
