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

from halo_jax import atomic, defaults


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
  atomic.write_text(path, config.to_json_best_effort(indent=1, sort_keys=True))


def read_config(path: str) -> ml_collections.ConfigDict:
  """A config written by write_config. Fields the file predates take their
  defaults (defaults.base_config), so code reads every field by name."""
  with open(path) as f:
    saved = json.load(f)
  return ml_collections.ConfigDict(_overlay(defaults.base_config().to_dict(), saved))


def _overlay(base: dict, saved: dict) -> dict:
  """`base` with every field of `saved` written over it, section by section."""
  for k, v in saved.items():
    base[k] = _overlay(base[k], v) if isinstance(v, dict) and isinstance(base.get(k), dict) \
        else v
  return base
