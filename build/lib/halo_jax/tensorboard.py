"""Optional TensorBoard event files beside metrics.jsonl (the source of truth).

Written through tensorboardX (`pip install -e '.[tb]'`), which needs no
TensorFlow; without it, `open_writer` returns None and nothing is written.
One event folder per stage, `<workdir>/tensorboard/<stage>`, with the stage's
own step as the x axis. A resumed stage opens its writer with `purge_step`,
so TensorBoard drops the points a killed run wrote after its last checkpoint
and a resumed run shows each step once.
"""
import os

import numpy as np


def available() -> bool:
  try:
    import tensorboardX  # pylint: disable=g-import-not-at-top,unused-import
  except ImportError:
    return False
  return True


def open_writer(workdir: str, stage: str, resume_step: int):
  """A tensorboardX SummaryWriter for `stage`, or None without tensorboardX."""
  if not available():
    return None
  import tensorboardX  # pylint: disable=g-import-not-at-top
  return tensorboardX.SummaryWriter(os.path.join(workdir, "tensorboard", stage),
                                    purge_step=resume_step + 1 if resume_step else None,
                                    flush_secs=30)


# metrics.jsonl fields -> TensorBoard tags (the held-out ones get a 'heldout/' prefix)
_SKIP = {"stage", "step", "heldout"}


def write_record(writer, record: dict, images=None) -> None:
  """One metrics.jsonl record as scalars (and held-out images [H, W, 3] in [0, 1])."""
  if writer is None:
    return
  step = int(record["step"])
  prefix = "heldout/" if record.get("heldout") else "train/"
  for key, value in record.items():
    if key in _SKIP or not isinstance(value, (int, float)) or isinstance(value, bool):
      continue
    tag = "time/wall_s" if key == "wall_s" else prefix + key
    writer.add_scalar(tag, float(value), step)
  for name, image in (images or {}).items():
    writer.add_image(f"heldout/{name}", np.clip(np.asarray(image), 0, 1), step,
                     dataformats="HWC")
