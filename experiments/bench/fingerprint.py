"""The fingerprint run: a short real run of a CPU-suite scene and method that
passes every step switch the suite's own run passes, under the 'budget'
protocol, scored; and the figures of it that a fingerprint hashes.

A suite run (benchmark.configure, mode 'budget') is changed in two ways only:
  - its sizes shrink (SIZES: widths, batches, samples, banks, the procedural
    scene), so that a step costs milliseconds; every setting that is not a
    size (rates, schedules, terms, scene-only fields, the collapse check,
    evaluation) stays the suite's;
  - each stage trains to the last step switch (SWITCHES) that the suite's
    run of it crosses at its budget, plus two log intervals. The count comes
    from a step table written for the run (`fingerprint_table`), so the
    'budget' protocol's whole path runs: shares, carry-over, floors, the
    reference clock of the front's snapshots and the held-out curve.

The run's figures (`figures`) are what a change of the training code could
move: every logged training loss, every held-out curve point, each stage's
steps and snapshot steps, whether each stage collapsed, and the final
held-out PSNR per view. code_version.py hashes them per method.

This module is the measuring instrument: same_numbers.py --commit copies it,
with the script, into a worktree of the commit it measures.
"""
import dataclasses
import json
import os

from halo_jax import frozen, protocol, sampler_switch, step_table
from experiments.bench import benchmark, suites
from halo_jax.configure import finish, set_field
from halo_jax.stages import collapse, metrics_log
from halo_jax.stages.order import needed

# Stage fields at which a step schedule switches (a step count each; 0: none).
SWITCHES = ("precrop_steps", "fg_steps", "collapse.after_steps", "empty.start_step",
            "joint.alpha_steps", "sampler.dense_eval_after", "sampler.switch_step")

# The sizes a fingerprint run shrinks, where the config has the field:
# (dotted field under each stage, value); then fields of the whole config.
STAGE_SIZES = (("model.width", 64), ("model.deform_width", 64), ("joint.model.width", 64),
               ("batch_rays", 512), ("sampler.num_samples", 16), ("bank_rays", 4096),
               ("target_rays", 16384), ("empty.bank_rays", 4096), ("empty.num_rays", 128),
               ("empty.num_samples", 16))
CONFIG_SIZES = (("baseline.num_samples", 16), ("data.procedural_size", 64),
                ("eval.curve_views", 1))


def _get(node, dotted):
  for part in dotted.split("."):
    if not hasattr(node, "keys") or part not in node:
      return None
    node = node[part]
  return node


def _set_if_present(config, dotted, value):
  if _get(config, dotted) is not None:
    set_field(config, dotted, value)


def suite_config(scene: suites.Scene, method: str, scratch: str, terms=suites.CPU,
                 overrides=()):
  """The seed-0 run of `scene` as `method` on a suite's terms (the CPU
  suite's, or a study's), with `overrides` ((dotted field, value) pairs),
  resolved at the suite's budget (benchmark.configure, mode 'budget')."""
  return benchmark.configure(terms, scene, method, 0, "budget", scratch, overrides)


def stage_steps(suite_cfg) -> dict:
  """{stage: steps} of the fingerprint run: the last switch the suite's run
  of the stage crosses, plus the log intervals the collapse check needs to
  judge steps after it (collapse.MIN_RECORDS + 1)."""
  out, trained = {}, protocol.effective(suite_cfg)
  for name in needed(suite_cfg, suite_cfg.final_stage):
    cfg = trained[name]
    reached = cfg.budget_steps or cfg.steps
    crossed = [v for v in (_get(cfg, f) for f in SWITCHES) if v and 0 < v <= reached]
    out[name] = max(crossed, default=0) + (collapse.MIN_RECORDS + 1) * max(cfg.log_every, 1)
  return out


def shrink(config):
  """config with the sizes of STAGE_SIZES and CONFIG_SIZES, in place."""
  for name in needed(config, config.final_stage):
    for field, value in STAGE_SIZES:
      _set_if_present(config[name], field, value)
  for field, value in CONFIG_SIZES:
    _set_if_present(config, field, value)
  return config


def fingerprint_table(config, counts: dict) -> dict:
  """A step table ({'entries': {key: entry}}) under which `config`'s budget
  gives each stage exactly counts[stage] steps (no set-up time)."""
  names = needed(config, config.final_stage)
  # keyed as the stages train (a budget's copy of Lo widens Hi's input); resolved
  # against the shipped table, since the one written here does not exist yet,
  # with no sampler switch (not in a key; the shipped table cannot price one
  # at the shrunk sizes)
  switches = [n for n in names if sampler_switch.switch_step(config[n])]
  keyed = protocol.effective(finish(frozen.replaced(
      config, {"step_table": "", **{f"{n}.sampler.switch_step": 0 for n in switches}})))
  shares = {n: config.budget_shares[n] for n in names}
  total = sum(shares.values())
  entries = {}
  for n in names:
    share_s = config.budget_s * shares[n] / total
    entry = {"step_s": share_s / counts[n], "setup_s": 0.0, "source": "fingerprint"}
    entries[step_table.key(keyed, n)] = entry
    if n in switches and counts[n] > sampler_switch.switch_step(config[n]):
      # its steps past its sampler switch, at the same rate
      entries[step_table.after_switch_key(keyed, n)] = entry
  return {"machine": {"source": "fingerprint run (experiments/bench/fingerprint.py)"},
          "entries": entries}


def configure(scene: suites.Scene, method: str, workdir: str, terms=suites.CPU, overrides=()):
  """(config, {stage: steps}): the fingerprint run of `scene` as `method`
  (on `terms` with `overrides`, as suite_config), its table written under
  `workdir`."""
  full = suite_config(scene, method, os.path.join(workdir, "scratch"), terms, overrides)
  counts = stage_steps(full)
  c = shrink(frozen.thaw(full))
  c.eval.lpips = False
  c.eval.save_images = False
  c.eval.flicker_frames = 3  # a dynamic scene's flicker video at its least
  for name in counts:
    c[name].checkpoint_every = 10 * counts[name]
  c.step_table = os.path.join(workdir, "fingerprint_steps.json")
  table = fingerprint_table(c, counts)
  with open(c.step_table, "w") as f:
    json.dump(table, f)
  protocol.budget(c, full.budget_s)
  c = finish(c)
  trained = protocol.effective(c)
  counts = {n: int(trained[n].budget_steps) for n in counts}
  return c, counts


def first_views(views, k):
  """The first k of a Views-like dataclass (every per-view field cut)."""
  n = len(views.names)
  cut = {f.name: getattr(views, f.name)[:k] for f in dataclasses.fields(views)
         if getattr(views, f.name) is not None and hasattr(getattr(views, f.name), "__len__")
         and len(getattr(views, f.name)) == n}
  return dataclasses.replace(views, **cut)


def run(scene: suites.Scene, method: str, workdir: str, views: int, terms=suites.CPU,
        overrides=()) -> dict:
  """The fingerprint run of `scene` as `method` (on `terms` with
  `overrides`, as configure) in `workdir`, scored on the first `views`
  held-out views: its figures."""
  from halo_jax import datasets, pipeline
  os.makedirs(workdir, exist_ok=True)
  c, _ = configure(scene, method, workdir, terms, overrides)
  ds = datasets.load(c.data, workdir)
  ds = dataclasses.replace(ds, test=first_views(ds.test, views))
  try:
    infos, collapsed = pipeline.run(c, workdir, ds), ""
  except collapse.Collapsed as e:  # an outcome like any other figure
    infos, collapsed = e.infos, e.stage
  return figures(workdir, infos, c.final_stage, collapsed)


def figures(workdir: str, infos: dict, final_stage: str, collapsed: str = "") -> dict:
  """What a fingerprint hashes of a finished (or collapsed) run in `workdir`:
  {'losses': {stage: [[step, loss]]}, 'heldout': {stage: [[step, psnr]]},
  'steps': {stage: step}, 'snapshots': {stage: [step]}, 'collapsed': stage or
  '', 'psnr': [final held-out PSNR per view]}, floats as computed."""
  from halo_jax.stages import snapshots
  losses, heldout = {}, {}
  for r in metrics_log.read(workdir):
    if r.get("heldout") and "psnr" in r:
      heldout.setdefault(r["stage"], []).append([r["step"], r["psnr"]])
    elif "loss" in r:
      losses.setdefault(r["stage"], []).append([r["step"], r["loss"]])
  final = (infos.get(final_stage) or {}).get("eval", {}).get("per_view", {})
  return {"losses": losses, "heldout": heldout,
          "steps": {n: int(i.get("step", 0)) for n, i in infos.items()},
          "snapshots": {n: [p["step"] for p in snapshots.read_index(workdir, n)] for n in infos},
          "collapsed": collapsed,
          "psnr": [final[v]["psnr"] for v in sorted(final)]}
