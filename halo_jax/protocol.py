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

`resolve` fixes the step counts once, before anything trains, from the
config alone; it writes only the stage fields it owns (`budget_steps`,
`ref_step_s`, `ref_setup_s`, `ref_offset_s`, `max_seconds`; under a budget,
`init_from_lo` and `encoding.with_lo` of a stage with `copy_lo_under_budget`)
and is idempotent, so the pipeline can resolve again what `configure`
resolved. A method states what it does under each protocol in fields
(`copy_lo_under_budget`) and never reads which protocol a run has: only
`resolve` does, after every override, in whatever order they came.
A stage with `schedule_span='stage'` (a recipe whose schedules are shares of
its run, the authors') is the one exception: once its length is fixed,
`steps` becomes that length and each field of SPANNED is rescaled with it,
so its rate, crop, L_empty start and window span the steps it trains
(resolving again finds the ratio 1 and changes nothing). A stage that
measures its own count has no length before it starts; its schedules stay
written against `steps`.

The reference clock of a stage is `ref_offset_s + ref_setup_s + step *
ref_step_s`: the front's snapshots (eval.front_s) and the held-out curve's
points (eval_every_s) are placed on it, so they fall at the same steps on any
machine; records keep their own wall-clock beside it.

A stage with no table entry (a size nobody measured) gets `max_seconds` of
its share instead: its loop measures its own step time on its first steps
after compilation and fixes its count there (stages/loop.py, `fixed_steps`
in its info, kept on resume). That count is this machine's, and the run's
record says so (`protocol.measured`).
"""
import math

from halo_jax import registry, step_table
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


def _clear(config, sections):
  """Resets the fields resolve owns (a budget owns max_seconds too; under
  the other protocols it is the user's time cap, which a loop also turns
  into steps after timing its first ones)."""
  for name in sections:
    for field in OWNED:
      config[name][field] = 0 if field == "budget_steps" else 0.0
    if config.protocol == "budget":
      config[name].max_seconds = 0.0


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
  """Fixes each stage's step count under config's protocol, in place; returns
  config (ConfigError as `problems` says). graph: config's stage graph
  (stages/order.graph), read once by the caller."""
  for message in problems(config, graph):
    raise registry.ConfigError(message)
  _clear(config, graph.sections)
  if config.protocol == "budget":
    _copy_lo(config, graph.sections)
    _budget_steps(config, graph.final)
  for name in graph.sections:
    if config[name].get("schedule_span", "steps") == "stage":
      _span_schedules(config[name])
  return config


def _copy_lo(config, sections):
  """Under the 'budget' protocol, each stage with `copy_lo_under_budget`
  starts as Lo-NeRF's exact copy (init_from_lo, encoding.with_lo): the few
  thousand steps a budget allows do not bring a field trained from scratch
  back to where Lo already is (methods/halo.py). Set before the step table is
  read: with_lo widens the stage's input, so it is part of the stage's key."""
  for name in sections:
    if config[name].get("copy_lo_under_budget", False):
      config[name].init_from_lo = True
      config[name].encoding.with_lo = True


def _span_schedules(cfg):
  """Rescales a stage's SPANNED fields from `steps` to the steps it trains
  (the budget's count, or stop_at_step where sooner), which becomes `steps`;
  a stage that measures its own count is left as it is."""
  if cfg.get("max_seconds", 0.0) and not cfg.get("budget_steps", 0):
    return
  length = min(cfg.steps, cfg.stop_at_step or cfg.steps, cfg.budget_steps or cfg.steps)
  ratio = length / max(cfg.steps, 1)
  for dotted in SPANNED:
    *path, field = dotted.split(".")
    node = cfg
    for part in path:
      node = node.get(part)
      if node is None:
        break
    if node is not None and node.get(field, 0) > 0:
      node[field] = max(1, round(node[field] * ratio))
  cfg.steps = length


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


def _budget_steps(config, final):
  """Each stage's budget_steps from the step table (module docstring)."""
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
      cfg.max_seconds = max(until - spent, 1e-3)
      spent = until
      continue
    # A floor is paid for by the shares after it; the last stage has none, so
    # it gets no floor and the method ends within its budget (equal time).
    floor = min(cfg.min_steps, cfg.steps) if name != names[-1] else 0
    cap = min(cfg.steps, cfg.stop_at_step or cfg.steps)
    # the step that crosses the share is taken, as a clock-stopped loop would
    count = math.ceil(max(until - spent - entry["setup_s"], 0.0) / entry["step_s"] - 1e-9)
    count = max(1, min(max(count, floor), cap))
    cfg.update(budget_steps=count, ref_step_s=float(entry["step_s"]),
               ref_setup_s=float(entry["setup_s"]), ref_offset_s=spent)
    spent += entry["setup_s"] + count * entry["step_s"]


def summary(config) -> dict:
  """What a record keeps of the protocol: its kind, budget, and per stage the
  steps fixed from the table (or 'measured' on this machine) with the key."""
  kind = config.get("protocol", "paper")
  out = {"kind": kind, "budget_s": float(config.budget_s)}
  if kind == "budget":
    out["stages"] = {n: ({"steps": int(config[n].budget_steps),
                          "step_s": config[n].ref_step_s, "setup_s": config[n].ref_setup_s,
                          "key": step_table.key(config, n)}
                         if config[n].ref_step_s else
                         {"measured": True, "seconds": config[n].max_seconds,
                          "key": step_table.key(config, n)})
                     for n in needed(config, config.final_stage)}
    out["measured"] = any(s.get("measured") for s in out["stages"].values())
  return out
