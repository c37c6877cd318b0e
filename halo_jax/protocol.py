"""A run's protocol, one value: how long each stage trains.

`config.protocol` is one of
  'paper'   each stage trains its `steps` (the paper's counts);
  'steps'   each stage trains its `steps`, or `stop_at_step` where that is
            sooner, the schedules still spanning `steps` (explicit caps);
  'budget'  `config.budget_s` *reference seconds*, split over the method's
            stages by `budget_shares`, each share turned into a step count
            from the committed table of step times (halo_jax/step_table.py),
            measured on one reference machine. A run then trains exactly those
            steps on any machine, fast or slow.

`resolve` works out, once and before anything trains, what the protocol
makes of the config, and writes it into one separate section, `config.plan`
({stage: the stage fields the protocol sets}), never into the fields a user
sets: each stage's `budget_steps` and reference clock (`ref_step_s`,
`ref_setup_s`, `ref_offset_s`); under a budget its `max_seconds`, and
`init_from_lo` and `encoding.with_lo` for a stage with
`copy_lo_under_budget`; for a stage with `schedule_span='stage'` its
`steps` and the SPANNED fields. A printed config thus shows what was asked
beside what was worked out. `effective(config)` is the config the stages
train with: each stage section with its plan laid over it (pipeline.run
makes it once). resolve reads only the user's fields, so resolving again
gives the same plan. A method states what it does under each protocol in
fields (`copy_lo_under_budget`) and never reads which protocol a run has:
only `resolve` does, after every override, in whatever order they came.
A stage with `schedule_span='stage'` (a recipe whose schedules are shares of
its run, the authors') trains for the length the protocol gives it, with
each field of SPANNED rescaled by that length over its `steps`, so its rate,
crop, L_empty start and window span the steps it trains. A stage that
measures its own count has no length before it starts; its schedules stay
written against `steps`.

The reference clock of a stage is `ref_offset_s + ref_setup_s + step *
ref_step_s` (past a sampler switch, halo_jax/sampler_switch.py, the steps
after it at the table's `ref_after_step_s`: `reference_seconds`): the front's snapshots (eval.front_s) and the held-out curve's
points (eval_every_s) are placed on it, so they fall at the same steps on any
machine; records keep their own wall-clock beside it.

A stage with no table entry (a size nobody measured) gets `max_seconds` of
its share instead: its loop measures its own step time on its first steps
after compilation and fixes its count there (stages/loop.py, `fixed_steps`
in its info, kept on resume). That count is this machine's, and the run's
record says so (`protocol.measured`).
"""
import math

import ml_collections

from halo_jax import config_files, frozen, registry, sampler_switch, step_table
from halo_jax.stages.budget import reference_seconds
from halo_jax.stages.order import needed, stage_names

KINDS = ("paper", "steps", "budget")
OWNED = ("budget_steps", "ref_step_s", "ref_setup_s", "ref_offset_s")
SPANS = ("steps", "stage")
# Step-valued schedule fields (dotted, under a stage) that schedule_span='stage'
# rescales to the steps the stage trains.
SPANNED = ("precrop_steps", "fg_steps", "lr_decay_steps", "empty.start_step",
           "joint.alpha_steps")


def budget(config, seconds: float):
  """Sets `config` to the 'budget' protocol: `seconds` reference seconds."""
  config.protocol, config.budget_s = "budget", float(seconds)
  return config


def steps(config, caps=None):
  """Sets `config` to the 'steps' protocol, each stage of `caps` ({stage:
  steps}) stopping there (stop_at_step) with its schedules spanning `steps`."""
  config.protocol, config.budget_s = "steps", 0.0
  for name, n in (caps or {}).items():
    config[name].stop_at_step = int(n)
  for name in stage_names(config):  # no clock: neither a time cap nor timed evaluations
    config[name].update(eval_every_s=0.0, max_seconds=0.0)
  return config


def paper(config):
  """Sets `config` to the 'paper' protocol: every stage trains its `steps`."""
  config.protocol, config.budget_s = "paper", 0.0
  for name in stage_names(config):
    config[name].update(eval_every_s=0.0, max_seconds=0.0)
  return config


def apply(config, protocol):
  """Sets `config` (in place) to `protocol`: 'paper', 'steps', or a number
  of reference seconds ('budget'). ValueError for anything else."""
  if protocol == "paper":
    return paper(config)
  if protocol == "steps":
    return steps(config)
  if isinstance(protocol, (int, float)) and not isinstance(protocol, bool) and protocol > 0:
    return budget(config, protocol)
  raise ValueError(f"protocol={protocol!r}: must be 'paper', 'steps' or a budget of reference "
                   "seconds > 0")


def problems(config, graph):
  """The one-line complaints (stages/order.Graph `graph`) about an unknown
  protocol, or a budget that does not fit it, first first (halo_jax/validate.py)."""
  kind = config.get("protocol", "paper")
  if kind not in KINDS:
    yield f"protocol={kind!r}: must be one of {list(KINDS)}"
  if not config.budget_s >= 0:
    yield f"budget_s={config.budget_s!r}: must be >= 0"
  if (config.budget_s > 0) != (kind == "budget"):
    yield (f"budget_s={config.budget_s!r} with protocol={kind!r}: a budget of reference "
           "seconds needs protocol='budget' and budget_s > 0; the other protocols have none")
  for name in graph.sections:
    span = config[name].get("schedule_span", "steps")
    if span not in SPANS:
      yield f"{name}.schedule_span={span!r}: must be one of {list(SPANS)}"
  if kind == "budget":
    shares = {n: config.budget_shares.get(n, None) for n in graph.final}
    missing = [n for n, v in shares.items() if v is None]
    if missing:
      yield f"budget_shares has no share for stage(s) {missing}"
    elif not (all(v >= 0 for v in shares.values()) and sum(shares.values()) > 0):
      yield (f"budget_shares {shares}: shares must be >= 0 and sum to more than 0 over "
             f"the stages {list(graph.final)}")


def resolve(config, graph):
  """Writes config.plan, what config's protocol makes of each stage (module
  docstring), in place; returns config (ConfigError as `problems` says).
  graph: config's stage graph (stages/order.graph), read once by the caller.
  No other field is written."""
  for message in problems(config, graph):
    raise registry.ConfigError(message)
  plan = {n: {f: (0 if f == "budget_steps" else 0.0) for f in OWNED} for n in graph.sections}
  if config.protocol == "budget":
    for name in graph.sections:  # a budget's share, or none
      plan[name]["max_seconds"] = 0.0
    _copy_lo(config, plan, graph.sections)
    # the copy widens a stage's input: the step table's key reads it from the plan
    config.plan = ml_collections.ConfigDict(plan)
    _budget_steps(config, plan, graph.final)
  for name in graph.sections:
    if config[name].get("schedule_span", "steps") == "stage":
      _span_schedules(config[name], plan[name])
  config.plan = ml_collections.ConfigDict(plan)
  return config


def _set(plan_stage, dotted, value):
  """plan_stage[<dotted>] = value, making the nested dicts on the way."""
  *path, field = dotted.split(".")
  node = plan_stage
  for part in path:
    node = node.setdefault(part, {})
  node[field] = value


def applied(tree: dict) -> dict:
  """A resolved config as a plain dict (its JSON) with each stage's plan laid
  over the stage and the plan section left out: what `effective` makes, for
  code that reads records. A config without a plan (a record written before
  the plan was a section of its own, whose stages already held these
  fields) is returned as it is."""
  out = dict(tree)
  for name, fields in (out.pop("plan", None) or {}).items():
    out[name] = config_files.laid_over(out[name], fields)
  return out


def effective(config):
  """The frozen config the stages train with: each stage section with its
  plan (config.plan) laid over it, the plan section left out. A config with
  no plan is returned as it is (`applied`)."""
  if "plan" not in config:
    return frozen.freeze(config)
  tree = frozen.thaw(config).to_dict()
  return frozen.freeze(ml_collections.ConfigDict(applied(tree)))


def _copy_lo(config, plan, sections):
  """Under the 'budget' protocol, each stage with `copy_lo_under_budget`
  starts as Lo-NeRF's exact copy (init_from_lo, encoding.with_lo, in its
  plan): the few thousand steps a budget allows do not bring a field trained
  from scratch back to where Lo already is (methods/halo.py)."""
  for name in sections:
    if config[name].get("copy_lo_under_budget", False):
      for dotted in ("init_from_lo", "encoding.with_lo"):
        _set(plan[name], dotted, True)


def _span_schedules(cfg, plan_stage):
  """A stage's length (the budget's count, or stop_at_step where sooner) as
  its plan's `steps`, and each SPANNED field rescaled from `steps` to it;
  a stage that measures its own count keeps its fields."""
  max_seconds = plan_stage.get("max_seconds", cfg.get("max_seconds", 0.0))
  if max_seconds and not plan_stage["budget_steps"]:
    return
  length = min(cfg.steps, cfg.stop_at_step or cfg.steps, plan_stage["budget_steps"] or cfg.steps)
  ratio = length / max(cfg.steps, 1)
  for dotted in SPANNED:
    *path, field = dotted.split(".")
    node = cfg
    for part in path:
      node = node.get(part)
      if node is None:
        break
    if node is not None and node.get(field, 0) > 0:
      _set(plan_stage, dotted, max(1, round(node[field] * ratio)))
  plan_stage["steps"] = length


def split(config, total: float, final) -> dict:
  """{stage: its part of `total`}: the one split of a budget (seconds, or a
  step count) over `final`, the stages config.final_stage needs
  (stages/order.Graph.final), by budget_shares."""
  shares = {n: config.budget_shares[n] for n in final}
  whole = sum(shares.values())
  return {n: total * share / whole for n, share in shares.items()}


def shares_until(config, final) -> dict:
  """{stage: budget seconds of the method's stages up to and including it}
  (`final` as `split` takes it)."""
  until, acc = {}, 0.0
  for name, part in split(config, config.budget_s, final).items():
    acc += part
    until[name] = acc
  return until


def _budget_steps(config, plan, final):
  """Each stage's budget_steps and reference clock from the step table
  (module docstring), into `plan`; config.plan holds the copy of Lo already."""
  parts = split(config, config.budget_s, final)
  table = step_table.load(config.get("step_table", ""))
  names = list(parts)
  until, spent, measuring = 0.0, 0.0, False
  for name in names:
    cfg = config[name]
    until += parts[name]
    entry = None if measuring else table.get(step_table.key(config, name))
    if entry is None:  # this machine measures it (stages/loop.py); so do the stages after it
      measuring = True
      plan[name]["max_seconds"] = max(until - spent, 1e-3)
      spent = until
      continue
    # A floor is paid for by the shares after it; the last stage has none, so
    # it gets no floor and the method ends within its budget (equal time).
    floor = min(cfg.min_steps, cfg.steps) if name != names[-1] else 0
    cap = min(cfg.steps, cfg.stop_at_step or cfg.steps)
    left = max(until - spent - entry["setup_s"], 0.0)
    # the step that crosses the share is taken, as a clock-stopped loop would
    count = math.ceil(left / entry["step_s"] - 1e-9)
    after_s = _after_switch_step_s(config, name, table, count)
    switch = sampler_switch.switch_step(cfg) if after_s else 0
    if after_s:  # the steps past the switch are priced at their own rate
      count = switch + math.ceil((left - switch * entry["step_s"]) / after_s - 1e-9)
    count = max(1, min(max(count, floor), cap))
    plan[name].update(budget_steps=count, ref_step_s=float(entry["step_s"]),
                      ref_setup_s=float(entry["setup_s"]), ref_offset_s=spent)
    if after_s and count > switch:  # only then: a run short of it has the plan it had
      plan[name].update(ref_switch_step=switch, ref_after_step_s=float(after_s))
    spent += reference_seconds(plan[name], count)


def _after_switch_step_s(config, name, table, count) -> float:
  """The table's step time of stage `name` past its sampler switch, where
  `count` steps at its first rate would pass the switch; 0.0 where they
  would not. ConfigError where the table lacks the key: the count could not
  be fixed before training."""
  switch = sampler_switch.switch_step(config[name])
  if not switch or count <= switch:
    return 0.0
  key = step_table.after_switch_key(config, name)
  if key not in table:
    raise registry.ConfigError(
        f"{name}.sampler.switch_step={switch}: the stage passes its switch under this budget, "
        f"and the step table has no entry for its steps after it ({key}); "
        "`python -m experiments.step_times` measures it")
  return float(table[key]["step_s"])


def summary(config) -> dict:
  """What a record keeps of the protocol: its kind, budget, and per stage the
  steps fixed from the table (or 'measured' on this machine) with the key.
  config: resolved (with its plan) or effective."""
  c = effective(config)
  kind = c.get("protocol", "paper")
  out = {"kind": kind, "budget_s": float(c.budget_s)}
  if kind == "budget":
    out["stages"] = {n: ({"steps": int(c[n].budget_steps),
                          "step_s": c[n].ref_step_s, "setup_s": c[n].ref_setup_s,
                          "key": step_table.key(c, n)}
                         if c[n].ref_step_s else
                         {"measured": True, "seconds": c[n].max_seconds,
                          "key": step_table.key(c, n)})
                     for n in needed(c, c.final_stage)}
    for n, stage in out["stages"].items():
      if c[n].get("ref_switch_step", 0):  # the steps past its sampler switch
        stage["after_switch"] = {"from_step": int(c[n].ref_switch_step),
                                 "step_s": c[n].ref_after_step_s,
                                 "key": step_table.after_switch_key(c, n)}
    out["measured"] = any(s.get("measured") for s in out["stages"].values())
  return out
