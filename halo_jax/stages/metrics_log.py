"""A run's `metrics.jsonl`: one JSON object a line, written by process 0 only."""
import json
import os

import jax


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

  def training_psnr(self, stage: str, key: str = "psnr") -> list:
    """[(step, batch PSNR)] of `stage`'s training records, in step order (the
    last of each step: a resumed run's records replace the killed run's);
    `key` reads another logged figure instead."""
    if not os.path.exists(self.path):
      return []
    by_step = {}
    with open(self.path) as f:
      for line in f:
        try:
          rec = json.loads(line)
        except json.JSONDecodeError:
          continue
        if rec.get("stage") == stage and not rec.get("heldout") and key in rec:
          by_step[int(rec["step"])] = float(rec[key])
    return sorted(by_step.items())

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
