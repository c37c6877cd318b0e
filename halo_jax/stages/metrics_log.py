"""A run's `metrics.jsonl`: one JSON object a line, written by process 0 only."""
import json
import os

import jax

from halo_jax import atomic


FILE = "metrics.jsonl"


def read(workdir: str) -> list:
  """A run's records so far, in order ([] where it has none). A line that does
  not parse is skipped: the last line of a log being written, or of a run
  killed mid-write. The one reader of the file: every tool reads it here."""
  path = os.path.join(workdir, FILE)
  if not os.path.exists(path):
    return []
  out = []
  with open(path) as f:
    for line in f:
      try:
        out.append(json.loads(line))
      except json.JSONDecodeError:
        continue
  return out


class MetricsLog:
  """Appends one JSON object a line to `<workdir>/metrics.jsonl`."""

  def __init__(self, workdir: str):
    os.makedirs(workdir, exist_ok=True)
    self.workdir = workdir
    self.path = os.path.join(workdir, FILE)

  def write(self, **record):
    if jax.process_index() != 0:  # multi-host: one log for the job
      return
    with open(self.path, "a") as f:
      f.write(json.dumps(record) + "\n")

  def training_psnr(self, stage: str, key: str = "psnr") -> list:
    """[(step, batch PSNR)] of `stage`'s training records, in step order (the
    last of each step: a resumed run's records replace the killed run's);
    `key` reads another logged figure instead."""
    by_step = {}
    for rec in read(self.workdir):
      if rec.get("stage") == stage and not rec.get("heldout") and key in rec:
        by_step[int(rec["step"])] = float(rec[key])
    return sorted(by_step.items())

  def drop_after(self, stage: str, step: int) -> None:
    """Removes `stage`'s records past `step` (written by a run killed after its
    last checkpoint), so a resumed run logs each step once. Atomic rewrite."""
    if jax.process_index() != 0 or not os.path.exists(self.path):
      return
    keep = [json.dumps(rec) + "\n" for rec in read(self.workdir)
            if not (rec.get("stage") == stage and rec.get("step", 0) > step)]
    atomic.write_text(self.path, "".join(keep))
