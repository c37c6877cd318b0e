"""The training loop every stage shares: jitted guarded steps, checkpoints, logs.

A stage supplies a pure `loss_fn(params, data, key, step) -> (loss, aux)`; the
loop owns the optimiser, the per-step PRNG key (`fold_in(seed, step)`, so a
resumed run draws exactly what an uninterrupted one would), the time budget,
held-out evaluations, checkpoints and `metrics.jsonl`.
"""
import copy
import json
import os
import time
from typing import Callable, Optional

import jax
import jax.numpy as jnp
import optax

from halo_jax import checkpoint, parallel, tensorboard
from halo_jax.stages import progress, snapshots


class MetricsLog:
  """Appends one JSON object a line to `<workdir>/metrics.jsonl`."""

  def __init__(self, workdir: str):
    os.makedirs(workdir, exist_ok=True)
    self.path = os.path.join(workdir, "metrics.jsonl")

  def write(self, **record):
    if jax.process_index() != 0:  # multi-host: one log for the job
      return
    with open(self.path, "a") as f:
      f.write(json.dumps(record) + "\n")

  def drop_after(self, stage: str, step: int) -> None:
    """Removes `stage`'s records past `step` (written by a run killed after its
    last checkpoint), so a resumed run logs each step once. Atomic rewrite."""
    if jax.process_index() != 0 or not os.path.exists(self.path):
      return
    with open(self.path) as f:
      lines = f.readlines()
    keep = []
    for line in lines:
      try:
        rec = json.loads(line)
      except json.JSONDecodeError:
        continue  # a line cut short by the kill
      if not (rec.get("stage") == stage and rec.get("step", 0) > step):
        keep.append(json.dumps(rec) + "\n")
    tmp = self.path + ".tmp"
    with open(tmp, "w") as f:
      f.writelines(keep)
    os.replace(tmp, self.path)


def schedule(cfg):
  """NeRF's log-linear learning rate, step -> lr: from lr_init to lr_final over
  `steps`, or by lr_final / lr_init every `lr_decay_steps` where that is set."""
  span = cfg.get("lr_decay_steps", 0) or max(cfg.steps, 1)
  return optax.exponential_decay(cfg.lr_init, transition_steps=span,
                                 decay_rate=cfg.lr_final / cfg.lr_init)


def optimizer(cfg) -> optax.GradientTransformation:
  """Adam with `schedule(cfg)`."""
  return optax.adam(schedule(cfg))


def minus_seconds(cfg, seconds):
  """A copy of a stage config whose time cap leaves room for `seconds` the stage
  already spent outside the loop (e.g. rendering Lo-NeRF targets)."""
  cfg = copy.deepcopy(cfg)
  if cfg.max_seconds:
    cfg.max_seconds = max(cfg.max_seconds - seconds, 1e-3)
  return cfg


# What a non-finite step went wrong in first, in the order a step computes them.
NONFINITE_WHAT = ("loss", "gradient", "update", "parameter")


class NonFiniteError(RuntimeError):
  """A stage's steps kept coming out non-finite; training cannot progress."""


def _nonfinite_leaves(tree):
  """[num_leaves] bool: which leaves of `tree` hold a non-finite entry."""
  return jnp.stack([~jnp.all(jnp.isfinite(x)) for x in jax.tree_util.tree_leaves(tree)])


def _diagnose(loss, grads, updates, params):
  """(ok, info): ok when loss, gradients, update and new parameters are all
  finite; info int32 [2] = (index into NONFINITE_WHAT of the first that is
  not, the index of its first non-finite leaf), (-1, -1) when ok."""
  bad = [~jnp.isfinite(loss)[None]] + [_nonfinite_leaves(t) for t in (grads, updates, params)]
  any_bad = jnp.stack([b.any() for b in bad])
  what = jnp.argmax(any_bad)
  leaf = jnp.select([what == k for k in range(4)], [jnp.argmax(b) for b in bad])
  ok = ~any_bad.any()
  return ok, jnp.where(ok, jnp.array([-1, -1]), jnp.stack([what, leaf]).astype(jnp.int32))


def part_of(x, part):
  """Part i of `num` equal parts of x [B, ...] along its first axis (x itself
  when part is None). part = (i, num), i may be traced; num divides B."""
  if part is None:
    return x
  i, num = part
  size = x.shape[0] // num
  return jax.lax.dynamic_slice_in_dim(x, i * size, size)


def check_parts(cfg, batch: int, what: str, mesh=None) -> None:
  """Raises unless cfg.microbatches splits `batch` (and each part splits over
  the data-parallel mesh)."""
  parts = cfg.microbatches
  if parts < 1 or batch % parts:
    raise ValueError(f"microbatches={parts} does not divide {what}={batch}")
  parallel.check_batch(mesh, batch // parts,
                       what if parts == 1 else f"{what}/microbatches")


def loss_and_grads(loss_fn: Callable, params, data, key, step, parts: int = 1):
  """((loss, aux), grads) of `loss_fn` on a step's batch, run in `parts` parts.

  Every loss here is a mean over rays of equal-size parts, so the mean of the
  parts' losses and gradients is the whole batch's; each part runs its forward
  and backward pass before the next starts, which keeps its activations in
  cache. aux entries are means over the parts.
  """
  value_and_grad = jax.value_and_grad(loss_fn, has_aux=True)
  if parts == 1:
    return value_and_grad(params, data, key, step)

  def add_part(total, i):
    out = value_and_grad(params, data, key, step, part=(i, parts))
    return jax.tree_util.tree_map(jnp.add, total, out), None

  shapes = jax.eval_shape(lambda: value_and_grad(params, data, key, step, part=(0, parts)))
  zeros = jax.tree_util.tree_map(lambda s: jnp.zeros(s.shape, s.dtype), shapes)
  total, _ = jax.lax.scan(add_part, zeros, jnp.arange(parts))
  return jax.tree_util.tree_map(lambda x: x / parts, total)


def make_step(loss_fn: Callable, tx: optax.GradientTransformation, parts: int = 1):
  """One jitted training step with a guard against non-finite values.

  A step whose loss, gradients, update or new parameters are not all finite
  leaves params and optimiser state untouched (and is counted in `skipped`);
  the step counter still advances so the next step draws fresh randomness.
  `streak` counts such steps in a row and `first_bad` records (step, what,
  leaf) of the streak's first step (what: NONFINITE_WHAT), so the loop can
  stop a stage that cannot progress and say why. `parts`: see loss_and_grads.
  """
  def step(train, data, base_key):
    key = jax.random.fold_in(base_key, train["step"])
    (loss, aux), grads = loss_and_grads(loss_fn, train["params"], data, key, train["step"],
                                        parts)
    updates, opt_state = tx.update(grads, train["opt_state"], train["params"])
    params = optax.apply_updates(train["params"], updates)
    ok, info = _diagnose(loss, grads, updates, params)
    keep = lambda new, old: jax.tree_util.tree_map(lambda a, b: jnp.where(ok, a, b), new, old)
    this = jnp.concatenate([train["step"][None], info])
    first = jnp.where(ok | (train["streak"] > 0), train["first_bad"], this)
    train = dict(params=keep(params, train["params"]),
                 opt_state=keep(opt_state, train["opt_state"]),
                 step=train["step"] + 1,
                 skipped=train["skipped"] + (1 - ok.astype(jnp.int32)),
                 streak=jnp.where(ok, 0, train["streak"] + 1),
                 first_bad=first)
    return train, loss, aux
  return jax.jit(step, donate_argnums=(0,))


def initial_state(params, tx, step: int = 0):
  """A fresh training state: params, optimiser state, step, skipped steps,
  the current run of non-finite steps and its first (step, what, leaf)."""
  return dict(params=params, opt_state=tx.init(params), step=jnp.int32(step),
              skipped=jnp.int32(0), streak=jnp.int32(0), first_bad=jnp.full((3,), -1, jnp.int32))


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
               board=None, snaps=None):
    self.name, self.cfg, self.state, self.wall_s = name, cfg, train_state, wall_s
    self.snaps = snaps  # snapshots.Snapshots or None
    self.mngr, self.log, self.eval_fn, self.wall_offset = mngr, log, eval_fn, wall_offset
    self.last_eval_s, self.last_log = wall_s, int(train_state["step"])
    self.last_eval_step = None
    self.board = board  # TensorBoard writer or None
    self.lr = schedule(cfg)

  def finish_step(self):
    """Waits for the step in flight, counting the wait as training time."""
    t0 = time.perf_counter()
    jax.block_until_ready(self.state)
    self.wall_s += time.perf_counter() - t0

  def evaluate(self, step):
    self.last_eval_step, self.last_eval_s = step, self.wall_s
    params = parallel.to_local(self.state["params"])
    metrics = dict(self.eval_fn(params, step))
    images = metrics.pop("images", {})  # for TensorBoard only
    metrics = {k: float(v) for k, v in metrics.items()}
    record = dict(stage=self.name, step=step, wall_s=self.wall_offset + self.wall_s,
                  heldout=True, **metrics)
    self.log.write(**record)
    if parallel.is_primary():
      tensorboard.write_record(self.board, record, images)

  def record(self, step, loss, aux, bar):
    self.finish_step()
    loss = float(loss)
    record = {k: float(v) for k, v in aux.items()}
    full = dict(stage=self.name, step=step, wall_s=self.wall_offset + self.wall_s, loss=loss,
                lr=float(self.lr(step - 1)), skipped=int(self.state["skipped"]), **record)
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
    if streak < self.cfg.get("max_nonfinite", 0) or not self.cfg.get("max_nonfinite", 0):
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
        cfg.eval_every_s and self.wall_s - self.last_eval_s >= cfg.eval_every_s)
    if due and self.eval_fn is not None:
      self.finish_step()
      self.evaluate(step)
    self.snapshot(step)

  def snapshot(self, step):
    """Saves the parameters as the front's point of every time this step
    reached (not counted as training time)."""
    if self.snaps is None:
      return
    times = self.snaps.due(self.wall_offset + self.wall_s)
    if times:
      self.finish_step()
      self.snaps.save(step, self.state["params"], self.wall_offset + self.wall_s, times)

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
          wall_offset: float = 0.0, mesh=None, snapshot_s=()):
  """Trains `params` on `loss_fn` for cfg.steps (or cfg.max_seconds, but never
  fewer than cfg.min_steps) and returns them.

  Args:
    name: stage name, used for the checkpoint folder and log records.
    cfg: the stage config (steps, lr_*, max_seconds, *_every).
    workdir: run folder; checkpoints go to <workdir>/<name>/checkpoints.
    params: initial parameters (ignored if a checkpoint exists: training resumes).
    loss_fn: (params, data, key, step, part=None) -> (loss, aux dict of scalars);
      with cfg.microbatches > 1 it is called on part=(i, microbatches) of its
      batch (part_of).
    data: pytree of device arrays the loss reads (rays, targets, ...).
    seed: base PRNG seed.
    eval_fn: (params, step) -> dict of held-out metrics (e.g. {'psnr': ...});
      its time is not counted as training time.
    log: metrics.jsonl writer.
    wall_offset: training seconds spent by earlier stages of the same method,
      added to wall_s in the log so curves of a whole pipeline line up.
    mesh: data-parallel mesh (parallel.make_mesh) or None; state and data are
      replicated on it and loss_fn shards its batch.
    snapshot_s: the method's training seconds (wall_offset included) at which
      to save the parameters for its error-against-time front (snapshots.py).

  Returns:
    (params, step, info) with info = {'wall_s', 'skipped', 'compile_s'}:
    training seconds exclude the step's compilation (compile_s) and held-out
    evaluations.
  """
  log = log or MetricsLog(workdir)
  tx = optimizer(cfg)
  train_state, wall_s, mngr = _start(name, workdir, params, tx, mesh, log)
  start = int(train_state["step"])
  board = tensorboard.open_writer(workdir, name, start) if parallel.is_primary() else None
  snaps = (snapshots.Snapshots(workdir, name, snapshot_s, start, wall_offset + wall_s)
           if snapshot_s else None)
  run = _Run(name, cfg, train_state, wall_s, mngr, log, eval_fn, wall_offset, board, snaps)
  data = parallel.replicate(data, mesh)
  base_key = jax.random.PRNGKey(seed)
  # Compiled before the clock starts: a time budget buys training steps, and
  # a method of three stages would otherwise pay three compilations.
  t0 = time.perf_counter()
  step_fn = make_step(loss_fn, tx, cfg.microbatches).lower(run.state, data, base_key).compile()
  compile_s = time.perf_counter() - t0
  bar = progress.ProgressBar(name, cfg, start, wall_s)
  try:
    step = _loop(run, step_fn, data, base_key, bar, start, cfg)
  finally:
    bar.close()  # before any error line, so it starts a line of its own
    if board is not None:
      board.close()
  info = {"wall_s": run.wall_s, "skipped": int(run.state["skipped"]), "compile_s": compile_s,
          # the time cap was reached before the floor of steps: trained past it
          "past_time_cap": bool(cfg.max_seconds and run.wall_s > cfg.max_seconds
                                and start < step <= cfg.get("min_steps", 0))}
  return parallel.to_local(run.state["params"]), step, info


def _loop(run, step_fn, data, base_key, bar, start, cfg):
  """Steps until cfg.steps or cfg.max_seconds; returns the last step taken."""
  step, in_flight = start, None  # in_flight: the loss of the step before the current one
  # The time cap stops a stage only after its floor of steps (min_steps), so
  # that no stage of a method is left untrained on a slow machine.
  floor = min(cfg.get("min_steps", 0), cfg.steps)
  for step in range(start + 1, progress.last_step(cfg) + 1):
    if cfg.max_seconds and run.wall_s >= cfg.max_seconds and step > floor:
      step -= 1
      break
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
    run.after_step(step, loss, aux, bar)
  run.close(step)
  return step
