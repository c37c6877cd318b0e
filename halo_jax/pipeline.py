"""Runs a config's stages in the order their declared needs imply, handing
each finished stage's immutable state to the stages that read it.

A stage section of the config (one whose `kind` names a registered trainer)
is trained by that trainer; the trainer says which finished stages it reads
(`requires`). `config.stages` lists what to train now; a needed stage that is
not in the list is restored from the workdir, where an earlier launch left
it. Nothing here branches on a model, sampler, method or data kind.
"""
import contextlib
import json
import os

from halo_jax import datasets, frozen, parallel, protocol, provenance, stages, validate
from halo_jax.frequency import tuning
from halo_jax import workdir_lock
from halo_jax.stages import base, budget, collapse, metrics_log
from halo_jax.stages.order import needed, parse_stages, stage_names
from halo_jax.stages.state import load, save, stage_dir
from halo_jax.stages.workdir import check_workdir


def _info_path(workdir, name):
  return os.path.join(stage_dir(workdir, name), "final", "info.json")


def _restored(config, name, dataset, workdir, train_now):
  """A needed stage this launch does not train: (its state, its info.json)
  from the workdir, or None where it trains now. That is a stage not in
  `train_now`, or one an earlier launch of this config finished at the step
  this config ends it at (a relaunch with more steps trains on from its
  checkpoint). collapse.Collapsed for a stage that was saved collapsed."""
  path = _info_path(workdir, name)
  if name in train_now:
    if not os.path.exists(path):
      return None
    with open(path) as f:
      if json.load(f).get("step", 0) < budget.last_step(config[name]):
        return None
  like = base.trainer_of(config, name).params_like(config, name, dataset)
  state = load(workdir, name, like)
  with open(path) as f:
    info = json.load(f)
  if collapse.collapsed(info):
    raise collapse.Collapsed(name, info["learned"], {name: info})
  return state, info


def run(config, workdir: str, dataset=None, pacer=None) -> dict:
  """Runs `config.stages` in `workdir`; returns {stage: info} for the stages run.

  dataset replaces the one config.data describes (a harness that hands the
  views over); pacer (stages/pacing.py) lets a driver grant every step.

  The config is validated and the data loaded before anything is written
  (a refused launch leaves the workdir as it was); then the workdir is
  locked for this process (workdir_lock: a second launch into it
  is refused). info holds the stage's training seconds ('wall_s'), steps,
  skipped steps, the verdict on whether it learned anything ('learned',
  stages/collapse.py) and, for stages that render images, the held-out
  evaluation and its verdict against the best constant image there
  ('heldout_learned'). A stage that collapsed is saved and raises collapse.Collapsed.
  """
  if not isinstance(config, frozen.Frozen):
    raise validate.ConfigError(
        "pipeline.run takes a composed, frozen config (configure.compose; configure.finish "
        f"for one edited by hand), not a mutable {type(config).__name__}")
  graph = validate.validate(config)
  as_json = lambda c: json.loads(c.to_json_best_effort())  # tuples and lists alike
  if as_json(protocol.resolve(frozen.thaw(config), graph)) != as_json(config):
    raise validate.ConfigError("the config's protocol is not resolved (its step counts were "
                               "edited after compose): make it with configure.compose or "
                               "configure.finish")
  # The data before the workdir's lock and config.json: a launch refused for
  # its input leaves nothing behind that would refuse the corrected one.
  dataset = dataset or datasets.load(config.data, workdir)
  # In a multi-process job the processes share the workdir; process 0 holds it.
  held = workdir_lock.hold(workdir) if parallel.is_primary() else contextlib.nullcontext()
  with held:
    return _run(config, graph, workdir, dataset, pacer)


def _run(resolved, graph, workdir, dataset, pacer):
  # what the stages train with: each stage with its plan laid over it
  config = protocol.effective(resolved)
  until = protocol.shares_until(config, graph.final) if config.protocol == "budget" else {}
  check_workdir(resolved, workdir)
  if config.lo.encoding.auto and "lo" in graph.run:
    # The search's own training time is not part of this run's budget.
    L, scale = tuning.chosen_encoding(resolved, workdir, dataset, run)
    config = frozen.replaced(config, {"lo.encoding.L": L, "lo.encoding.scale": scale})
  log = metrics_log.MetricsLog(workdir)
  mesh = parallel.make_mesh(config.parallel)
  # wall: this machine's training seconds; spent: the method's reference
  # seconds (halo_jax/protocol.py), which place the next stage's front points
  states, infos, wall, spent = {}, {}, 0.0, 0.0
  heldout_constant = None  # the best constant image's PSNR on the held-out views
  origin = provenance.collect()  # once a run: every stage's info carries it
  for name in graph.run:
    restored = _restored(config, name, dataset, workdir, graph.launch)
    if restored:
      # nothing compiled, rendered or recomputed (a resumed run goes on from there)
      states[name], info = restored
      wall += info["wall_s"]
      spent = info.get("reference_end_s", spent + info["wall_s"])
      if name in graph.launch:
        infos[name] = info
      continue
    stage_config = budget.measured_share(config, name, until, spent)
    ctx = base.StageContext(stage_config, name, dataset, workdir, dict(states), log, spent, mesh,
                            pacer)
    state, info = base.trainer_of(stage_config, name).train(ctx)
    wall += info["wall_s"]
    spent = info["reference_end_s"]
    info.update(step=int(state.step), cumulative_wall_s=wall)
    if "eval" in info:
      # a field can fit its training rays and render background everywhere else;
      # a measurement, not a judgement of training: short stages get it too
      if heldout_constant is None:
        heldout_constant = collapse.constant_psnr(dataset.test.images)
      info["heldout_learned"] = collapse.heldout(info["eval"]["psnr"], heldout_constant,
                                                 config[name].collapse.margin_db)
    save(workdir, state)
    if parallel.is_primary():
      info["provenance"] = origin
      with open(_info_path(workdir, name), "w") as f:
        json.dump(info, f, indent=1)
    states[name], infos[name] = state, info
    if collapse.collapsed(info):  # saved for a look, never handed on
      raise collapse.Collapsed(name, info["learned"], infos)
  return infos


def _cell(value, fmt, width):
  """A metric, or '-' where the stage has none (the ray field has no images)."""
  return f"{'-':>{width}}" if value is None else f"{value:{width}{fmt}}"


def table(infos) -> str:
  """The stages' steps, training seconds and held-out metrics, one line each."""
  lines = [f"{'stage':6} {'steps':>6} {'train s':>8} {'PSNR':>7} {'SSIM':>6} {'LPIPS':>6} "
           "learned"]
  for name, info in infos.items():
    ev = info.get("eval", {})
    lines.append(f"{name:6} {info['step']:6d} {info['wall_s']:8.1f} "
                 f"{_cell(ev.get('psnr'), '.2f', 7)} {_cell(ev.get('ssim'), '.3f', 6)} "
                 f"{_cell(ev.get('lpips'), '.3f', 6)} "
                 f"{(info.get('learned') or {}).get('verdict', '-')}")
  return "\n".join(lines)


__all__ = ["needed", "parse_stages", "run", "stage_names", "table", "stages"]
