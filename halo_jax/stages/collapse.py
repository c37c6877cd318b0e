"""Did a stage learn anything? Its training PSNR against the best constant image's.

A radiance stage that has collapsed (e.g. a NeRF that stayed the empty field
and renders the background everywhere) is no better on its own training rays
than one constant colour. The best constant prediction under the squared
error is the training pixels' mean colour; a field that learned the scene
beats it by several dB within a few hundred steps. So, over the last window
of logged steps (each log line's batch PSNR):

  collapsed  the median training PSNR is under the constant's + margin_db
  learned    it is not
  unchecked  the stage trained fewer than `after_steps` steps (a smoke run),
             or logged no training PSNR (the ray field: no images)

A collapsed stage is never handed on silently: the pipeline saves it, writes
the verdict to its info.json and raises `Collapsed` (one line, exit 2).
"""
import statistics
from typing import Optional, Sequence, Tuple

import numpy as np

LEARNED, COLLAPSED, UNCHECKED = "learned", "collapsed", "unchecked"
# Each record is one batch's PSNR: the median of at least this many.
MIN_RECORDS = 5


class Collapsed(RuntimeError):
  """A stage did not beat the best constant image on its own training rays.

  `stage` names it, `verdict` is `verdict()`'s dict, `infos` the infos of the
  stages run so far, the collapsed one included (its held-out evaluation too)."""

  def __init__(self, stage: str, verdict: dict, infos: dict):
    self.stage, self.verdict, self.infos = stage, verdict, infos
    super().__init__(
        f"stage {stage!r} collapsed: its training PSNR over steps {verdict['window'][0]}-"
        f"{verdict['window'][1]} was {verdict['train_psnr']:.2f} dB, not "
        f"{verdict['margin_db']:g} dB above the best constant image's "
        f"{verdict['constant_psnr']:.2f} dB (the training pixels' mean colour), so it learned "
        f"nothing and was not handed on. Try another seed, {stage}.precrop_steps (a centre "
        f"crop for its first steps) or {stage}.lr_init; its state and info.json are in the "
        "workdir.")


def constant_psnr(rgb: np.ndarray) -> float:
  """PSNR of the best constant prediction (the mean colour) of pixels rgb [..., 3]."""
  rgb = np.asarray(rgb, np.float64).reshape(-1, rgb.shape[-1])
  mse = float(((rgb - rgb.mean(0)) ** 2).mean())
  return float("inf") if mse == 0.0 else -10.0 * np.log10(mse)


def verdict(train_psnr: Sequence[Tuple[int, float]], constant: Optional[float], *,
            margin_db: float, after_steps: int, window: float) -> dict:
  """The verdict on a stage from its logged (step, training PSNR) records.

  Args:
    train_psnr: [(step, batch PSNR)] in step order, as logged.
    constant: `constant_psnr` of the stage's training pixels (None: unchecked).
    margin_db: how far above the constant a stage that learned must be.
    after_steps: stages that stopped before this step are not judged.
    window: the judged records are those in the last `window` of the steps
      trained (at least the last MIN_RECORDS records).

  Returns:
    {'verdict', 'train_psnr', 'constant_psnr', 'margin_db', 'window': [first
    step, last step]} ('unchecked' has no PSNRs when nothing was logged).
  """
  out = {"verdict": UNCHECKED, "margin_db": margin_db, "after_steps": after_steps}
  if constant is None or not train_psnr:
    return out
  last = train_psnr[-1][0]
  tail = [r for r in train_psnr if r[0] >= last * (1.0 - window)]
  tail = tail if len(tail) >= MIN_RECORDS else list(train_psnr[-MIN_RECORDS:])
  psnr = statistics.median(p for _, p in tail)
  out.update(train_psnr=float(psnr), constant_psnr=float(constant),
             window=[int(tail[0][0]), int(last)])
  if last < after_steps:
    return out
  out["verdict"] = LEARNED if psnr >= constant + margin_db else COLLAPSED
  return out


def collapsed(info: dict) -> bool:
  """Whether a stage's info (pipeline) carries a collapsed verdict."""
  return (info.get("learned") or {}).get("verdict") == COLLAPSED
