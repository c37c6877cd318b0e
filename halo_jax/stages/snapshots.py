"""A stage's parameters saved at given training times of its method: the
points of the run's error-against-time front, scored after training
(experiments/bench/front_scores.py) so that scoring never counts as training time.

Times are the method's reference seconds (earlier stages included, the
loop's `clock`: under a budget the step table's, so a point falls at the
same step on any machine); each point keeps this machine's seconds too. A stage saves a snapshot at the first step
that ends at or past each time after the earlier stages' training (its own
set-up, such as rendering Lo-NeRF's targets, included); one snapshot serves
every time a single step crosses. Files:

  <workdir>/<stage>/snapshots/params/<step>/  orbax, {'params': ...}
  <workdir>/<stage>/snapshots/index.json {'points': [{'at_s', 'step', 'wall_s'}, ...]}

A resumed stage keeps the points up to its restored step and saves the rest
again as it crosses them.
"""
import json
import os
from typing import Sequence

from halo_jax import atomic, checkpoint, parallel


def folder(workdir: str, name: str) -> str:
  return os.path.join(workdir, name, "snapshots")


def read_index(workdir: str, name: str) -> list:
  """[{'at_s', 'step', 'wall_s'}, ...] of stage `name`, by time ([] if none)."""
  path = os.path.join(folder(workdir, name), "index.json")
  if not os.path.exists(path):
    return []
  with open(path) as f:
    return sorted(json.load(f)["points"], key=lambda p: p["at_s"])


def _manager(workdir: str, name: str):
  return checkpoint.manager(os.path.join(folder(workdir, name), "params"), max_to_keep=None)


def load_params(workdir: str, name: str, step: int, params_like):
  """The parameters stage `name` had after `step`, as saved by a Snapshots."""
  return checkpoint.restore(_manager(workdir, name), step, {"params": params_like})["params"]


class Snapshots:
  """The snapshots one stage owes: `due(total_s)` after each step, `save`
  when it is."""

  def __init__(self, workdir: str, name: str, times_s: Sequence[float], start_step: int,
               start_total_s: float):
    self.workdir, self.name = workdir, name
    kept = [p for p in read_index(workdir, name) if p["step"] <= start_step]
    done = {p["at_s"] for p in kept}
    self.points = kept
    # A fresh stage owes every time it is given (those within an earlier
    # stage's span are not given it), including those its set-up outlasted;
    # a resumed one, those it had not reached by its restored step.
    self.pending = sorted(t for t in times_s
                          if t not in done and (start_step == 0 or t > start_total_s))
    self.mngr = None

  def due(self, total_s: float) -> list:
    """The pending times that `total_s` training seconds have reached."""
    return [t for t in self.pending if t <= total_s]

  def save(self, step: int, params, total_s: float, times: Sequence[float]) -> None:
    """Saves `params` after `step` as the point of each of `times`."""
    if self.mngr is None:
      self.mngr = _manager(self.workdir, self.name)
    if step not in self.mngr.all_steps():
      checkpoint.save(self.mngr, step, {"params": parallel.to_local(params)})
    self.pending = [t for t in self.pending if t not in times]
    self.points = [p for p in self.points if p["at_s"] not in times] + [
        {"at_s": float(t), "step": int(step), "wall_s": float(total_s)} for t in times]
    if parallel.is_primary():
      path = os.path.join(folder(self.workdir, self.name), "index.json")
      atomic.write_json(path, {"points": sorted(self.points, key=lambda p: p["at_s"])},
                        indent=1)
