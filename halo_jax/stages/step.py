"""The jitted training step every stage shares: Adam on NeRF's log-linear
schedule, gradients over micro-batches, and a guard that leaves the state
untouched by a step that is not finite.

A stage supplies a pure `loss_fn(params, data, key, step) -> (loss, aux)`; the
step's PRNG key is `fold_in(seed, step)`, so a resumed run draws exactly what
an uninterrupted one would.
"""
from typing import Callable

import jax
import jax.numpy as jnp
import optax


def schedule(cfg):
  """The learning rate, step -> lr: with lr_power > 0 a polynomial of that
  power from lr_init to lr_final over `steps` (mmcv's Poly); else NeRF's
  log-linear decay from lr_init to lr_final over `steps`, or by lr_final /
  lr_init every `lr_decay_steps` where that is set."""
  if cfg.get("lr_power", 0.0) > 0:
    return optax.polynomial_schedule(cfg.lr_init, cfg.lr_final, cfg.lr_power,
                                     max(cfg.steps, 1))
  span = cfg.lr_decay_steps or max(cfg.steps, 1)
  return optax.exponential_decay(cfg.lr_init, transition_steps=span,
                                 decay_rate=cfg.lr_final / cfg.lr_init)


def optimizer(cfg) -> optax.GradientTransformation:
  """Adam with `schedule(cfg)`."""
  return optax.adam(schedule(cfg))


# What a non-finite step went wrong in first, in the order a step computes them.
NONFINITE_WHAT = ("loss", "gradient", "update", "parameter")


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
