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
import tqdm

from halo_jax import checkpoint, parallel


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


def optimizer(cfg) -> optax.GradientTransformation:
  """Adam with NeRF's log-linear decay: from lr_init to lr_final over `steps`,
  or by lr_final / lr_init every `lr_decay_steps` where that is set."""
  span = cfg.get("lr_decay_steps", 0) or max(cfg.steps, 1)
  schedule = optax.exponential_decay(cfg.lr_init, transition_steps=span,
                                     decay_rate=cfg.lr_final / cfg.lr_init)
  return optax.adam(schedule)


def minus_seconds(cfg, seconds):
  """A copy of a stage config whose time cap leaves room for `seconds` the stage
  already spent outside the loop (e.g. rendering Lo-NeRF targets)."""
  cfg = copy.deepcopy(cfg)
  if cfg.max_seconds:
    cfg.max_seconds = max(cfg.max_seconds - seconds, 1e-3)
  return cfg


def _all_finite(tree):
  leaves = jax.tree_util.tree_leaves(tree)
  return jnp.all(jnp.stack([jnp.all(jnp.isfinite(x)) for x in leaves]))


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
  """One jitted training step with a guard against non-finite losses or gradients.

  A step whose loss or gradients are not finite leaves params and optimiser
  state untouched (and is counted); the step counter still advances so the
  next step draws fresh randomness. `parts`: see loss_and_grads.
  """
  def step(train, data, base_key):
    key = jax.random.fold_in(base_key, train["step"])
    (loss, aux), grads = loss_and_grads(loss_fn, train["params"], data, key, train["step"],
                                        parts)
    ok = jnp.isfinite(loss) & _all_finite(grads)
    updates, opt_state = tx.update(grads, train["opt_state"], train["params"])
    params = optax.apply_updates(train["params"], updates)
    keep = lambda new, old: jax.tree_util.tree_map(lambda a, b: jnp.where(ok, a, b), new, old)
    train = dict(params=keep(params, train["params"]),
                 opt_state=keep(opt_state, train["opt_state"]),
                 step=train["step"] + 1,
                 skipped=train["skipped"] + (1 - ok.astype(jnp.int32)))
    return train, loss, aux
  return jax.jit(step, donate_argnums=(0,))


def train(name: str, cfg, workdir: str, params, loss_fn: Callable, data, seed: int,
          eval_fn: Optional[Callable] = None, log: Optional[MetricsLog] = None,
          wall_offset: float = 0.0, mesh=None):
  """Trains `params` on `loss_fn` for cfg.steps (or cfg.max_seconds) and returns them.

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

  Returns:
    (params, step, info) with info = {'wall_s', 'skipped'}.
  """
  log = log or MetricsLog(workdir)
  tx = optimizer(cfg)
  step_fn = make_step(loss_fn, tx, cfg.microbatches)
  train_state = dict(params=params, opt_state=tx.init(params), step=jnp.int32(0),
                     skipped=jnp.int32(0))
  mngr = checkpoint.manager(os.path.join(workdir, name, "checkpoints"))
  restored = checkpoint.restore_latest(mngr, dict(train_state, wall_s=0.0))
  wall_s = 0.0
  if restored is not None:
    wall_s = float(restored.pop("wall_s"))
    train_state = restored
  train_state = parallel.replicate(train_state, mesh)
  data = parallel.replicate(data, mesh)
  start = int(train_state["step"])
  log.drop_after(name, start)
  base_key = jax.random.PRNGKey(seed)
  last_eval_s, last_log, last_eval_step = wall_s, start, None

  def evaluate(step):
    nonlocal last_eval_step
    last_eval_step = step
    metrics = {k: float(v) for k, v in eval_fn(train_state["params"], step).items()}
    log.write(stage=name, step=step, wall_s=wall_offset + wall_s, heldout=True, **metrics)
    return metrics

  def finish_step():
    """Waits for the step in flight, counting the wait as training time."""
    nonlocal wall_s
    t0 = time.perf_counter()
    jax.block_until_ready(train_state)
    wall_s += time.perf_counter() - t0

  bar = tqdm.tqdm(total=cfg.steps, initial=start, desc=name, dynamic_ncols=True,
                  mininterval=1.0)
  step = start
  in_flight = None  # the loss of the step before the current one
  for step in range(start + 1, cfg.steps + 1):
    if cfg.max_seconds and wall_s >= cfg.max_seconds:
      step -= 1
      break
    t0 = time.perf_counter()
    train_state, loss, aux = step_fn(train_state, data, base_key)
    # Keep one step in flight: wait for the previous step, not this one, so
    # the device never idles while Python dispatches (1-2 ms a step on a
    # GPU), and wall_s, which the budget reads, lags the device by <= 1 step.
    if in_flight is not None:
      in_flight.block_until_ready()
    in_flight = loss
    wall_s += time.perf_counter() - t0
    bar.update(1)
    if step % cfg.log_every == 0 or step == cfg.steps:
      finish_step()
      loss = float(loss)
      record = {k: float(v) for k, v in aux.items()}
      log.write(stage=name, step=step, wall_s=wall_offset + wall_s, loss=loss,
                skipped=int(train_state["skipped"]), **record)
      shown = {"loss": f"{loss:.4g}"}
      if "psnr" in record:
        shown["psnr"] = f"{record['psnr']:.2f}"
      bar.set_postfix(**shown)
      last_log = step
    if step % cfg.checkpoint_every == 0:
      finish_step()
      checkpoint.save(mngr, step, dict(train_state, wall_s=wall_s))
    due = (cfg.eval_every and step % cfg.eval_every == 0) or (
        cfg.eval_every_s and wall_s - last_eval_s >= cfg.eval_every_s)
    if due and eval_fn is not None:
      finish_step()
      evaluate(step)
      last_eval_s = wall_s
  finish_step()
  bar.close()
  if last_log != step:
    log.write(stage=name, step=step, wall_s=wall_offset + wall_s,
              skipped=int(train_state["skipped"]))
  if mngr.latest_step() != step:
    checkpoint.save(mngr, step, dict(train_state, wall_s=wall_s))
  if eval_fn is not None and (cfg.eval_every or cfg.eval_every_s) and last_eval_step != step:
    evaluate(step)
  return train_state["params"], step, {"wall_s": wall_s,
                                       "skipped": int(train_state["skipped"])}
