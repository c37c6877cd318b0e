"""The host loop every stage shares: the time budget, held-out evaluations,
checkpoints, snapshots for the front and the metrics log around the jitted
step (stages/step.py).
"""
import os
import time
from typing import Callable, Optional

import jax

from halo_jax import checkpoint, parallel, tensorboard
from halo_jax.stages import (budget, collapse, pacing, preemption, progress, selection,
                             self_timed, snapshots)
from halo_jax.stages.metrics_log import MetricsLog
from halo_jax.stages.step import NONFINITE_WHAT, initial_state, make_step, optimizer, schedule


class NonFiniteError(RuntimeError):
  """A stage's steps kept coming out non-finite; training cannot progress."""


def _start(name, workdir, params, tx, mesh, log):
  """(train_state, training seconds so far, checkpoint manager): restored
  from the latest checkpoint if there is one, else fresh; placed on `mesh`."""
  train_state = initial_state(params, tx)
  mngr = checkpoint.manager(os.path.join(workdir, name, "checkpoints"))
  restored = checkpoint.restore_latest(mngr, dict(train_state, wall_s=0.0))
  wall_s = 0.0
  if restored is not None:
    wall_s = float(restored.pop("wall_s"))
    train_state = restored
  log.drop_after(name, int(train_state["step"]))
  return parallel.replicate(train_state, mesh), wall_s, mngr


class _Run:
  """One stage's loop state: the train state, its clock and its records."""

  def __init__(self, name, cfg, train_state, wall_s, mngr, log, eval_fn, wall_offset,
               board=None, snaps=None, pacer=None, select=None, workdir="", switch_step=0):
    self.name, self.cfg, self.state, self.wall_s = name, cfg, train_state, wall_s
    self.workdir = workdir
    self.start_step, self.start_wall = int(train_state["step"]), wall_s
    # the loop's last step, which a self-measuring stage (max_seconds) fixes
    # on the way, and a resumed one keeps
    self.timed = self_timed.SelfTimed(cfg, workdir, name, switch_step,
                                      (self.start_step, self.start_wall))
    self.select = select  # (selection.Best, select_fn) or None
    self.snaps = snaps  # snapshots.Snapshots or None
    self.pacer = pacer  # pacing.Pacer or None
    self.mngr, self.log, self.eval_fn, self.wall_offset = mngr, log, eval_fn, wall_offset
    self.last_eval_s, self.last_log = self.clock(self.start_step), self.start_step
    self.last_eval_step = None
    self.board = board  # TensorBoard writer or None
    self.lr = schedule(cfg)
    self.compile_s = 0.0  # compiling its steps, off the clock

  def clock(self, step) -> float:
    """The method's reference seconds after `step` (halo_jax/protocol.py):
    the table's step time from the stage's reference offset, else this
    machine's (self-measured, then fixed) from the wall-clock offset. The
    front's snapshots and the curve's evaluations are placed on it."""
    cfg = self.cfg
    if cfg.get("ref_step_s", 0.0):
      return budget.reference_seconds(cfg, step, cfg.ref_offset_s)
    if self.timed.step_s:
      return self.wall_offset + self.start_wall + self.timed.seconds(self.start_step, step)
    return self.wall_offset + self.wall_s

  @property
  def last(self) -> int:
    return self.timed.last

  def fix_count(self, step) -> bool:
    """A self-measuring stage fixes its count when it has timed enough
    steps (self_timed.py), and says so; returns whether it did."""
    if not self.timed.due(step, self.wall_s):
      return False
    self.finish_step()
    what = self.timed.fix(step, self.wall_s)
    if parallel.is_primary():
      self.timed.write()
      print(f"stage {self.name}: no reference step time for its sizes; {what} (this machine's "
            "count: `python -m experiments.step_times` adds the entry)", flush=True)
    return True

  def at_switch(self, step):
    """The loop is at its sampler switch (or resumed past it)."""
    self.finish_step()
    self.timed.at_switch(step, self.wall_s)

  def finish_step(self):
    """Waits for the step in flight, counting the wait as training time."""
    t0 = time.perf_counter()
    jax.block_until_ready(self.state)
    self.wall_s += time.perf_counter() - t0

  def evaluate(self, step):
    self.last_eval_step, self.last_eval_s = step, self.clock(step)
    params = parallel.to_local(self.state["params"])
    metrics = dict(self.eval_fn(params, step))
    images = metrics.pop("images", {})  # for TensorBoard only
    metrics = {k: float(v) for k, v in metrics.items()}
    record = dict(stage=self.name, step=step, wall_s=self.wall_offset + self.wall_s,
                  reference_s=self.clock(step), heldout=True, **metrics)
    if self.select is not None:  # model selection on the validation views
      best, select_fn = self.select
      record["select_psnr"] = float(select_fn(params, step))
      best.offer(step, record["select_psnr"], params)
    self.log.write(**record)
    if parallel.is_primary():
      tensorboard.write_record(self.board, record, images)

  def record(self, step, loss, aux, bar):
    self.finish_step()
    loss = float(loss)
    record = {k: float(v) for k, v in aux.items()}
    full = dict(stage=self.name, step=step, wall_s=self.wall_offset + self.wall_s,
                reference_s=self.clock(step), loss=loss, lr=float(self.lr(step - 1)),
                skipped=int(self.state["skipped"]), **record)
    self.log.write(**full)
    if parallel.is_primary():
      tensorboard.write_record(self.board, full)
    shown = {"loss": f"{loss:.4g}"}
    if "psnr" in record:
      shown["psnr"] = f"{record['psnr']:.2f}"
    bar.set_postfix(**shown)
    self.last_log = step

  def save(self, step):
    self.finish_step()
    checkpoint.save(self.mngr, step, dict(self.state, wall_s=self.wall_s))

  def check_progress(self, step):
    """NonFiniteError once `max_nonfinite` steps in a row were non-finite."""
    streak = int(self.state["streak"])
    if not self.cfg.max_nonfinite or streak < self.cfg.max_nonfinite:
      return
    first_step, what, leaf = (int(x) for x in jax.device_get(self.state["first_bad"]))
    name = NONFINITE_WHAT[what]
    where = ""
    if name != "loss":
      paths = [jax.tree_util.keystr(p) for p, _ in
               jax.tree_util.tree_leaves_with_path(self.state["params"])]
      where = f" in leaf {paths[leaf]}" if 0 <= leaf < len(paths) else ""
    fields = f"{self.name}.lr_init, {self.name}.lr_final"
    if name in ("loss", "gradient"):  # a huge step before, or the loss itself
      fields += (f", {self.name}.batch_rays, {self.name}.sampler, the loss terms' weights and "
                 "the data")
    raise NonFiniteError(
        f"stage {self.name!r}: {streak} steps in a row up to step {step} were not finite "
        f"(limit {self.name}.max_nonfinite={self.cfg.max_nonfinite}); the first, step "
        f"{first_step + 1}, had a non-finite {name}{where}. Check {fields}. The stage was "
        f"not saved as finished; its last checkpoint holds the last finite parameters.")

  def after_step(self, step, loss, aux, bar):
    """Logs, checkpoints and evaluates when they are due; stops a stage whose
    steps keep coming out non-finite."""
    cfg = self.cfg
    if step % cfg.log_every == 0 or step == cfg.steps:
      self.record(step, loss, aux, bar)
      self.check_progress(step)
    if step % cfg.checkpoint_every == 0:
      self.save(step)
    due = (cfg.eval_every and step % cfg.eval_every == 0) or (
        cfg.eval_every_s and self.clock(step) - self.last_eval_s >= cfg.eval_every_s)
    if due and self.eval_fn is not None:
      self.finish_step()
      bar.evaluating()
      self.evaluate(step)
      bar.resume()
    self.snapshot(step)

  def snapshot(self, step):
    """Saves the parameters as the front's point of every time this step
    reached (not counted as training time)."""
    if self.snaps is None:
      return
    times = self.snaps.due(self.clock(step))
    if times:
      self.finish_step()
      self.snaps.save(step, self.state["params"], self.wall_offset + self.wall_s, times)

  def paced(self, step, loss, aux):
    """Hands the step to the driver of a paced run (stages/pacing.py)."""
    metrics = {"loss": float(loss), **{k: float(v) for k, v in aux.items()}}
    self.pacer.report(pacing.StepRecord(self.name, step, self.state["params"], metrics))

  def stop(self, step, signum):
    """Saves step `step` (logged, checkpointed) and raises Preempted."""
    self.finish_step()
    if self.last_log != step:
      self.log.write(stage=self.name, step=step, wall_s=self.wall_offset + self.wall_s,
                     skipped=int(self.state["skipped"]))
    if self.mngr.latest_step() != step:
      checkpoint.save(self.mngr, step, dict(self.state, wall_s=self.wall_s))
    raise preemption.Preempted(signum, f"in stage {self.name!r} at step {step}, its "
                               "checkpoint saved")

  def close(self, step):
    """The last log line, checkpoint and evaluation of a stopped loop."""
    cfg = self.cfg
    self.finish_step()
    self.check_progress(step)
    self.snapshot(step)  # a time the last step's wait reached
    if self.last_log != step:
      self.log.write(stage=self.name, step=step, wall_s=self.wall_offset + self.wall_s,
                     skipped=int(self.state["skipped"]))
    if self.mngr.latest_step() != step:
      checkpoint.save(self.mngr, step, dict(self.state, wall_s=self.wall_s))
    if (self.eval_fn is not None and (cfg.eval_every or cfg.eval_every_s)
        and self.last_eval_step != step):
      self.evaluate(step)


def train(name: str, cfg, workdir: str, params, loss_fn: Callable, data, seed: int,
          eval_fn: Optional[Callable] = None, log: Optional[MetricsLog] = None,
          wall_offset: float = 0.0, mesh=None, snapshot_s=(), pacer=None,
          baseline: Optional[collapse.Baseline] = None, select_fn: Optional[Callable] = None,
          switch: Optional[tuple] = None):
  """Trains `params` on `loss_fn` for cfg.steps (or cfg.max_seconds, but never
  fewer than cfg.min_steps) and returns them.

  Checkpoints go to <workdir>/<name>/checkpoints; an existing one resumes
  training (`params` ignored). loss_fn: (params, data, key, step, part=None)
  -> (loss, aux dict of scalars), called on part=(i, microbatches) of its
  batch when cfg.microbatches > 1; data: the device arrays it reads. eval_fn:
  (params, step) -> held-out metrics; log: the metrics.jsonl writer, wall_s
  offset by the earlier stages' wall_offset so a pipeline's curves line up.
  mesh: a data-parallel mesh (parallel.make_mesh; state and data replicated,
  loss_fn shards its batch) or None. snapshot_s: the method's training
  seconds (wall_offset included) at which to save the parameters for its
  error-against-time front (snapshots.py). pacer: a pacing.Pacer whose driver
  grants every step (None: free). baseline: the collapse check's (None: not
  judged). select_fn: (params, step) -> PSNR on validation views at every
  held-out evaluation; the best parameters are returned (selection.py).
  switch: (step, loss_fn) or None: the steps after the first `step` take
  this loss_fn (a sampler switch, halo_jax/sampler_switch.py), its step
  compiled when the loop reaches it (or at the start of a resumed run past
  it), off the clock like the first.

  Returns:
    (params, step, info), info = {'wall_s', 'skipped', 'compile_s', 'past_time_cap',
    'learned' (collapse.verdict)[, 'selected': {'step', 'psnr'}]}; wall_s excludes
    compilation (compile_s), held-out evaluations and selection scores.
  """
  log = log or MetricsLog(workdir)
  tx = optimizer(cfg)
  train_state, wall_s, mngr = _start(name, workdir, params, tx, mesh, log)
  start = int(train_state["step"])
  board = tensorboard.open_writer(workdir, name, start) if parallel.is_primary() else None
  run = _Run(name, cfg, train_state, wall_s, mngr, log, eval_fn, wall_offset, board, None, pacer,
             select_fn and (selection.Best(workdir, name), select_fn), workdir,
             switch[0] if switch else 0)
  if snapshot_s:
    run.snaps = snapshots.Snapshots(workdir, name, snapshot_s, start, run.clock(start))
  data = parallel.replicate(data, mesh)
  base_key = jax.random.PRNGKey(seed)
  bar = progress.ProgressBar(name, cfg, start, wall_s)  # says so while the step compiles
  try:
    # Compiled before the clock starts: a time budget buys training steps, and
    # a method of three stages would otherwise pay three compilations.
    step_fn, later = _steps(run, tx, data, base_key, loss_fn, switch, start)
    with preemption.training():
      step = _loop(run, step_fn, data, base_key, bar, start, cfg, later)
  finally:
    bar.close()  # before any error line, so it starts a line of its own
    if board is not None:
      board.close()
  info = _info(run, start, step, run.compile_s, baseline)
  return _chosen(run, info), step, info


def _steps(run, tx, data, base_key, loss_fn, switch, start):
  """(the compiled step the loop starts with, (switch step, () -> the
  compiled step after it) or None); compiling counts in run.compile_s."""
  def compiled(fn):
    t0 = time.perf_counter()
    out = make_step(fn, tx, run.cfg.microbatches).lower(run.state, data, base_key).compile()
    run.compile_s += time.perf_counter() - t0
    return out

  switch_step, after_fn = switch if switch else (0, None)
  if switch_step and start >= switch_step:  # resumed past the switch
    loss_fn, switch_step = after_fn, 0
  return compiled(loss_fn), ((switch_step, lambda: compiled(after_fn)) if switch_step else None)


def _chosen(run, info):
  """The stage's result: its last parameters, or the best on the selection
  views (info['selected'] then says which step's)."""
  final = parallel.to_local(run.state["params"])
  best = run.select[0] if run.select else None
  if best is None or best.record is None:
    return final
  info["selected"] = dict(best.record)
  return best.params(final)


def _info(run, start, step, compile_s, baseline) -> dict:
  """`train`'s info of a finished loop that began at `start` and ended at `step`."""
  cfg = run.cfg
  return {"wall_s": run.wall_s, "skipped": int(run.state["skipped"]), "compile_s": compile_s,
          # the method's reference seconds at the stage's end (the next stage's offset)
          "reference_end_s": run.clock(step),
          # the floor of steps outlasted the stage's share of the budget
          "past_time_cap": bool(cfg.max_seconds and run.timed.step_s
                                and run.timed.seconds(0, step) > cfg.max_seconds
                                and step <= cfg.min_steps),
          **({"fixed_steps": run.last, "measured_step_s": run.timed.step_s}
             if run.timed.step_s else {}),
          **({"measured_after_step_s": run.timed.after_s} if run.timed.after_s else {}),
          "learned": collapse.judge(
              run.log.training_psnr(run.name, baseline.key if baseline else "psnr"), baseline,
              # the crop's and the foreground start's batches are not the constant's pixels
              judged_from=max(cfg.get("precrop_steps", 0), cfg.get("fg_steps", 0)),
              **cfg.collapse)}


def _loop(run, step_fn, data, base_key, bar, start, cfg, later=None):
  """Steps until the stage's last step (run.last, which a self-measuring
  stage fixes on the way); returns the last step taken. later: (switch step,
  () -> the compiled step after it) or None."""
  step, in_flight = start, None  # in_flight: the loss of the step before the current one
  if run.timed.switch_step and start >= run.timed.switch_step:
    run.at_switch(start)
  while step < run.last:
    if later is not None and step == later[0]:
      step_fn, later = later[1](), None
      run.at_switch(step)
    step += 1
    if run.pacer is not None:
      run.pacer.wait_turn(run)
    t0 = time.perf_counter()
    run.state, loss, aux = step_fn(run.state, data, base_key)
    # Keep one step in flight: wait for the previous step, not this one, so
    # the device never idles while Python dispatches (1-2 ms a step on a
    # GPU), and wall_s, which the budget reads, lags the device by <= 1 step.
    if in_flight is not None:
      in_flight.block_until_ready()
    in_flight = loss
    dt = time.perf_counter() - t0
    run.wall_s += dt
    bar.advance(step, dt, run.wall_s)
    # the bar counts steps once the count is fixed (or was, before a resume)
    if run.fix_count(step) or (bar.timed and run.timed.fixed):
      bar.to_steps(step, run.last, cfg.max_seconds, run.timed.step_s)
    run.after_step(step, loss, aux, bar)
    if run.pacer is not None:
      run.paced(step, loss, aux)
    if preemption.requested() is not None:
      run.stop(step, preemption.requested())
  run.close(step)
  return step
