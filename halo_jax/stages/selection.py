"""Model selection on validation views: a stage keeps the parameters that
scored best on views that are neither training nor test views, as the
authors keep their Blender `best.pth` by its PSNR on 13 val views.

The loop offers the parameters at every held-out evaluation; the best are
saved, so a resumed stage keeps them. Files:

  <workdir>/<stage>/best/params/<step>/  orbax, {'params': ...} (the best only)
  <workdir>/<stage>/best/record.json     {'step', 'psnr'}
"""
import json
import os
from typing import Optional

from halo_jax import atomic, checkpoint, parallel


def folder(workdir: str, name: str) -> str:
  return os.path.join(workdir, name, "best")


def read_record(workdir: str, name: str) -> Optional[dict]:
  """{'step', 'psnr'} of the best parameters saved so far, or None."""
  path = os.path.join(folder(workdir, name), "record.json")
  if not os.path.exists(path):
    return None
  with open(path) as f:
    return json.load(f)


class Best:
  """The best parameters of one stage on its selection views."""

  def __init__(self, workdir: str, name: str):
    self.workdir, self.name = workdir, name
    self.record = read_record(workdir, name)
    self.mngr = checkpoint.manager(os.path.join(folder(workdir, name), "params"), max_to_keep=1)

  def offer(self, step: int, psnr: float, params) -> bool:
    """Saves `params` (after `step`, scoring `psnr`) if they beat the best so
    far; returns whether they did."""
    if self.record is not None and psnr <= self.record["psnr"]:
      return False
    checkpoint.save(self.mngr, step, {"params": parallel.to_local(params)})
    self.record = {"step": int(step), "psnr": float(psnr)}
    if parallel.is_primary():
      path = os.path.join(folder(self.workdir, self.name), "record.json")
      atomic.write_json(path, self.record)
    return True

  def params(self, like):
    """The best parameters, in the structure of `like` (None before any offer)."""
    if self.record is None:
      return None
    return checkpoint.restore(self.mngr, self.record["step"], {"params": like})["params"]
