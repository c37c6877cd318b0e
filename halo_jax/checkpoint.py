"""Checkpoints (orbax): atomic saves of a stage's training state, and resume.

Orbax writes each step into a temporary folder and renames it when complete,
so a run killed mid-save leaves the previous checkpoint intact.
"""
import json
import os
from typing import Optional

import jax
import ml_collections
import orbax.checkpoint as ocp


def manager(directory: str, max_to_keep: Optional[int] = 2) -> ocp.CheckpointManager:
  """Checkpoints of one folder, the newest `max_to_keep` kept (None: all)."""
  return ocp.CheckpointManager(
      os.path.abspath(directory),
      options=ocp.CheckpointManagerOptions(max_to_keep=max_to_keep, create=True))


def save(mngr: ocp.CheckpointManager, step: int, tree) -> None:
  mngr.save(step, args=ocp.args.StandardSave(tree), force=True)
  mngr.wait_until_finished()


def restore_latest(mngr: ocp.CheckpointManager, like):
  """The latest checkpoint restored into the structure of `like`, or None."""
  step = mngr.latest_step()
  if step is None:
    return None
  return restore(mngr, step, like)


def restore(mngr: ocp.CheckpointManager, step: int, like):
  """Checkpoint `step` restored into the structure of `like`."""
  abstract = jax.tree_util.tree_map(ocp.utils.to_shape_dtype_struct, like)
  return mngr.restore(step, args=ocp.args.StandardRestore(abstract))


def write_config(path: str, config: ml_collections.ConfigDict) -> None:
  os.makedirs(os.path.dirname(path), exist_ok=True)
  tmp = path + ".tmp"
  with open(tmp, "w") as f:
    f.write(config.to_json_best_effort(indent=1, sort_keys=True))
  os.replace(tmp, path)


def read_config(path: str) -> ml_collections.ConfigDict:
  with open(path) as f:
    return ml_collections.ConfigDict(json.load(f))
