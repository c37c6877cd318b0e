"""A finished stage's output: an immutable pytree handed to the next stage."""
import os

import flax
import jax
import ml_collections
import numpy as np

from halo_jax import checkpoint, parallel
from halo_jax.types import Params


class StageMissing(FileNotFoundError):
  """A stage that this launch needs has not finished in the workdir."""


@flax.struct.dataclass
class StageState:
  """Parameters of a trained field, the step it reached, and the config that made it.

  Attributes:
    params: the field's parameters (a pytree of arrays).
    step: training steps taken.
    config: the full run config (static, not a pytree leaf).
    name: 'lo', 'ray' or 'hi'.
  """
  params: Params
  step: int
  config: ml_collections.ConfigDict = flax.struct.field(pytree_node=False)
  name: str = flax.struct.field(pytree_node=False)


def stage_dir(workdir: str, name: str) -> str:
  return os.path.join(workdir, name)


def load(workdir: str, name: str, params_like) -> StageState:
  """Loads stage `name`'s final state from `workdir` (written by a finished stage)."""
  d = stage_dir(workdir, name)
  final = os.path.join(d, "final")
  if not os.path.exists(os.path.join(final, "config.json")):
    raise StageMissing(
        f"{final}: stage {name!r} has not finished in this workdir; run it first "
        f"(--config.stages={name})")
  config = checkpoint.read_config(os.path.join(final, "config.json"))
  mngr = checkpoint.manager(os.path.join(final, "params"), max_to_keep=1)
  restored = checkpoint.restore_latest(mngr, {"params": params_like, "step": 0})
  return StageState(restored["params"], int(restored["step"]), config, name)


def save(workdir: str, state: StageState) -> None:
  final = os.path.join(stage_dir(workdir, state.name), "final")
  mngr = checkpoint.manager(os.path.join(final, "params"), max_to_keep=1)
  if int(state.step) in mngr.all_steps():
    # A run killed between saving these params and writing config.json: the
    # resumed run reached the same step, so replace them.
    mngr.delete(int(state.step))
  params = state.params
  if jax.process_count() > 1:
    # one process's copy of the (replicated) parameters: orbax saves host
    # arrays once, from its primary process
    params = jax.tree_util.tree_map(np.asarray, params)
  checkpoint.save(mngr, int(state.step), {"params": params, "step": int(state.step)})
  # config.json last: its presence marks the stage as finished.
  if parallel.is_primary():
    checkpoint.write_config(os.path.join(final, "config.json"), state.config)
