"""A finished run, back from its workdir: config, data, stage states, renderer.

Used by the evaluate and render commands, which work on any finished stage
that makes images, of any scene kind, without retraining anything.
"""
import dataclasses
import os
from typing import Any, Callable, Dict, Optional

from halo_jax import checkpoint, datasets, frozen
from halo_jax.stages import base, order, state
from halo_jax.types import Config


class NothingToRestore(ValueError):
  """The workdir has no finished stage of the kind asked for."""


@dataclasses.dataclass(frozen=True)
class Restored:
  workdir: str
  config: Config              # the stage's config, as it was trained
  stage: str
  dataset: datasets.Dataset
  states: Dict[str, state.StageState]      # the stage and every stage it reads, by name
  render: Callable            # fn(o, d[, t]) -> {'rgb', 'depth', 'acc', ...}


def finished(workdir: str, name: str) -> bool:
  return os.path.exists(os.path.join(state.stage_dir(workdir, name), "final", "config.json"))


def default_stage(workdir: str) -> Optional[str]:
  """The run's output stage (its config's final_stage) if it finished, else
  the last finished stage that makes images."""
  path = os.path.join(workdir, "config.json")
  if not os.path.exists(path):
    return None
  config = checkpoint.read_config(path)
  names = [config.final_stage] + list(reversed(order.stage_names(config)))
  return next((n for n in names if finished(workdir, n)
               and base.trainer_of(config, n).renderer is not None), None)


def stage_states(workdir: str, config, dataset, names) -> Dict[str, Any]:
  """{name: StageState} of the finished stages `names` (StageMissing names
  one that has not finished)."""
  return {n: state.load(workdir, n, base.trainer_of(config, n).params_like(config, n, dataset))
          for n in names}


def _laid_over(config, fields):
  """`config` with each (dotted field, value) of `fields` set; a field a run
  stored before the field existed is added where today's base config has it
  (KeyError naming any other unknown field)."""
  from halo_jax import defaults  # pylint: disable=import-outside-toplevel
  out, base_fields = frozen.thaw(config), None
  for dotted, value in fields:
    try:
      frozen.set_field(out, dotted, value)
    except KeyError:
      base_fields = base_fields or defaults.base_config()
      frozen.set_field(base_fields, dotted, value)  # raises for a field nowhere
      *parents, leaf = dotted.split(".")
      node = out
      for p in parents:
        node = node[p]
      node[leaf] = value
  return frozen.freeze(out)


def load(workdir: str, stage: Optional[str] = None, data_root: str = "",
         render_overrides=()) -> Restored:
  """Restores `stage` (default: default_stage) of the run in `workdir`.

  data_root replaces the config's data.root (for a run trained elsewhere).
  render_overrides: (dotted field, value) pairs laid over the stored config
  before the renderer is made (how the trained parameters are rendered,
  e.g. `hi.sampler.dense_eval_after`; the parameters are as trained).
  Raises NothingToRestore naming the workdir and stage when there is none.
  """
  name = stage or default_stage(workdir)
  if name is None or not finished(workdir, name):
    raise NothingToRestore(f"{workdir}: no finished stage {stage or '(any that renders)'} "
                           "to restore (train it first: python -m halo_jax.cli.train ...)")
  config = frozen.freeze(checkpoint.read_config(
      os.path.join(state.stage_dir(workdir, name), "final", "config.json")))
  trainer = base.trainer_of(config, name)
  if trainer.renderer is None:
    raise NothingToRestore(f"{workdir}: stage {name!r} ({config[name].kind}) makes no "
                           "images; choose one that does (e.g. --stage=hi)")
  if data_root:  # a new value: the run's config as stored, its scene elsewhere
    config = frozen.replaced(config, {"data.root": data_root})
  if render_overrides:
    config = _laid_over(config, render_overrides)
  dataset = datasets.load(config.data, workdir)
  states = stage_states(workdir, config, dataset, order.needed(config, name))
  return Restored(workdir, config, name, dataset, states,
                  base.renderer_of(config, name, dataset, states))
