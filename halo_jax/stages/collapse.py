"""Did a stage learn anything? Its fit against the best constant prediction's.

A radiance stage that has collapsed (e.g. a NeRF that stayed the empty field
and renders the background everywhere) is no better on its own training rays
than one constant colour. The best constant prediction under the squared
error is the training pixels' mean colour; a field that learned the scene
beats it by several dB within a few hundred steps. The ray field is judged
alike: its L_ray in dB against the constant depth and opacity's (the targets'
means). Only records whose batches are drawn like the constant's pixels
count: those after the centre crop and the foreground start (`judged_from`),
whose batches are biased towards the object. Over the last window of those
logged steps (each log line's batch figure):

  collapsed  the median is under the constant's + margin_db
  learned    it is not
  unjudged   fewer than MIN_RECORDS records after `judged_from` (too short
             a stage past its crop to tell)
  unchecked  the stage trained fewer than `after_steps` steps (a smoke run),
             or logged nothing to judge

A collapsed stage is never handed on silently: the pipeline saves it, writes
the verdict to its info.json and raises `Collapsed` (one line, exit 2).

Training rays alone miss a field that fits its views with floaters and
renders background everywhere else, so a stage's held-out render is judged
too (`heldout`): its PSNR against the best constant image of those views.
That verdict flags the run's figures; it stops nothing.
"""
import statistics
from typing import NamedTuple, Optional, Sequence, Tuple

import numpy as np

LEARNED, COLLAPSED, UNJUDGED, UNCHECKED = "learned", "collapsed", "unjudged", "unchecked"
# Each record is one batch's PSNR: the median of at least this many.
MIN_RECORDS = 5


class Collapsed(RuntimeError):
  """A stage did not beat the best constant prediction on its own training rays.

  `stage` names it, `verdict` is `verdict()`'s dict, `infos` the infos of the
  stages run so far, the collapsed one included (its held-out evaluation too)."""

  def __init__(self, stage: str, verdict: dict, infos: dict):
    self.stage, self.verdict, self.infos = stage, verdict, infos
    figure = verdict.get("figure", "training PSNR")
    constant = verdict.get("constant", "the training pixels' mean colour")
    crop = ("" if "figure" in verdict  # no pixels, no crop
            else f", {stage}.precrop_steps (a centre crop for its first steps)")
    super().__init__(
        f"stage {stage!r} collapsed: its {figure} over steps {verdict['window'][0]}-"
        f"{verdict['window'][1]} was {verdict['train_psnr']:.2f} dB, not "
        f"{verdict['margin_db']:g} dB above the best constant prediction's "
        f"{verdict['constant_psnr']:.2f} dB ({constant}), so it learned nothing and was not "
        f"handed on. Try another seed{crop} or {stage}.lr_init; its state and info.json are "
        "in the workdir.")


class Baseline(NamedTuple):
  """What a stage is judged against: the best constant prediction's figure
  (dB), the logged figure compared with it (`in_db` False: a mean squared
  error, read in dB by fit_db), and both in words."""
  db: float
  key: str = "psnr"
  in_db: bool = True
  figure: str = "training PSNR"
  constant: str = "the training pixels' mean colour"


def pixels_baseline(rgb: np.ndarray) -> Baseline:
  """A radiance stage's baseline: the mean colour of its training pixels rgb [..., 3]."""
  return Baseline(constant_psnr(rgb))


def targets_baseline(depth, acc, far: float, weights=(1.0,)) -> Baseline:
  """The ray field's baseline: L_ray of the best constant depth and opacity
  (the targets' means) on its batches, which draw each target source [R_i]
  of depth and acc with `weights` (the sources' shares of a batch)."""
  w = np.asarray(weights, np.float64) / np.sum(weights)
  mse = 0.0
  for xs in ([np.asarray(d, np.float64) / far for d in depth],
             [np.asarray(a, np.float64) for a in acc]):
    mean = sum(wi * x.mean() for wi, x in zip(w, xs))
    mse += sum(wi * ((x - mean) ** 2).mean() for wi, x in zip(w, xs))
  return Baseline(fit_db(mse), key="loss", in_db=False, figure="L_ray in dB (-10 log10 L_ray)",
                  constant="Lo-NeRF's targets' mean depth and opacity")


def constant_psnr(rgb: np.ndarray, rows: int = 1 << 20) -> float:
  """PSNR of the best constant prediction (the mean colour) of pixels rgb [..., 3].
  Accumulated in float64 over `rows` pixels at a time: a paper-size test
  split is never copied whole to float64."""
  rgb = np.asarray(rgb).reshape(-1, rgb.shape[-1])
  chunks = [rgb[i:i + rows] for i in range(0, rgb.shape[0], rows)]
  mean = sum(c.sum(0, dtype=np.float64) for c in chunks) / rgb.shape[0]
  mse = float(sum(((c - mean) ** 2).sum() for c in chunks) / rgb.size)
  return float("inf") if mse == 0.0 else -10.0 * np.log10(mse)


def fit_db(mse) -> float:
  """A mean squared error in dB, as PSNR reads it (-10 log10 mse)."""
  mse = float(mse)
  return float("inf") if mse <= 0.0 else -10.0 * float(np.log10(mse))


def judge(records: Sequence[Tuple[int, float]], baseline: Optional[Baseline], *,
          judged_from: int = 0, **collapse_cfg) -> dict:
  """`verdict` against a Baseline, its words carried in the verdict for the
  Collapsed message; collapse_cfg: the stage's `collapse` fields."""
  if baseline is None:
    return verdict(records, None, judged_from=judged_from, **collapse_cfg)
  if not baseline.in_db:
    records = [(s, fit_db(v)) for s, v in records]
  out = verdict(records, baseline.db, judged_from=judged_from, **collapse_cfg)
  if baseline.key != "psnr":
    out.update(figure=baseline.figure, constant=baseline.constant)
  return out


def verdict(train_psnr: Sequence[Tuple[int, float]], constant: Optional[float], *,
            margin_db: float, after_steps: int, window: float, judged_from: int = 0) -> dict:
  """The verdict on a stage from its logged records train_psnr [(step, batch
  PSNR)] in step order (the record at step s: the s-th step's batch, counted
  from 1) against `constant`, the constant_psnr of its training pixels (None:
  unchecked). A stage that learned is margin_db above it over the last
  `window` of the steps trained (at least MIN_RECORDS records); a stage that
  stopped before after_steps is not judged, nor are the records up to
  judged_from (biased batches: the centre crop, the foreground start).
  Returns {'verdict', 'margin_db', 'after_steps', 'judged_from'[,
  'train_psnr', 'constant_psnr', 'window': [first step, last step]]} (no
  figures when nothing was logged after `judged_from`).
  """
  out = {"verdict": UNCHECKED, "margin_db": margin_db, "after_steps": after_steps,
         "judged_from": int(judged_from)}
  if constant is None or not train_psnr:
    return out
  last = train_psnr[-1][0]
  fair = [r for r in train_psnr if r[0] > judged_from]
  tail = [r for r in fair if r[0] >= last * (1.0 - window)]
  tail = tail if len(tail) >= MIN_RECORDS else fair[-MIN_RECORDS:]
  if tail:
    out.update(train_psnr=float(statistics.median(p for _, p in tail)),
               constant_psnr=float(constant), window=[int(tail[0][0]), int(last)])
  if last < after_steps:
    return out
  if len(tail) < MIN_RECORDS:
    out["verdict"] = UNJUDGED
    return out
  out["verdict"] = LEARNED if out["train_psnr"] >= constant + margin_db else COLLAPSED
  return out


def heldout(psnr: float, constant: float, margin_db: float) -> dict:
  """The verdict on a stage's held-out render: its PSNR on the held-out views
  against the best constant image of those views (`constant_psnr` of their
  pixels, an oracle's constant: no field is judged on a colour it could not
  know). A stage under constant + margin_db renders nothing of the scene
  there, whatever it fitted on its training rays."""
  return {"verdict": LEARNED if psnr >= constant + margin_db else COLLAPSED,
          "psnr": float(psnr), "constant_psnr": float(constant), "margin_db": margin_db}


def collapsed(info: dict) -> bool:
  """Whether a stage's info (pipeline) carries a collapsed verdict."""
  return (info.get("learned") or {}).get("verdict") == COLLAPSED

