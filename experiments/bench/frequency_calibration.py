"""Calibrating the frequency rule's threshold across scenes (leave-one-scene-out).

Each scene contributes its full grid: rows (high to low frequency) with the
criterion rho and Lo-NeRF's held-out PSNR. For a threshold tau the rule picks
a point per scene (tuning.decide, the rule `auto` runs); its regret is the
scene's best grid PSNR minus the pick's. A threshold is chosen on some scenes
as the one with the least mean regret over them (ties: the median of the tied
candidates), then evaluated on a scene it never saw.
"""
from typing import Dict, List, Sequence

import numpy as np

from halo_jax.frequency import tuning


def scored(scenes: Dict[str, dict], relative: bool, key: str = "criterion") -> Dict[str, dict]:
  """The scenes with each row's 'criterion' taken from `key` (e.g.
  'criterion_warped') and its 'score', what the threshold is compared with
  (tuning.score)."""
  out = {}
  for name, s in scenes.items():
    first = s["grid"][0][key]
    grid = [dict(r, criterion=r[key], score=tuning.score(r[key], first, relative))
            for r in s["grid"]]
    out[name] = dict(s, grid=grid)
  return out


def pick(rows: Sequence[dict], tau: float, hi_freq: float) -> dict:
  """The grid row the rule chooses at threshold tau."""
  grid = [(r["L"], r["scale"]) for r in rows]
  chosen, _ = tuning.decide(list(rows), grid, tau, hi_freq)
  return next(r for r in rows if (r["L"], r["scale"]) == (chosen["L"], chosen["scale"]))


def regret(rows: Sequence[dict], tau: float, hi_freq: float) -> float:
  """Best grid PSNR minus the PSNR of the rule's pick at tau (dB, >= 0)."""
  return max(r["psnr"] for r in rows) - pick(rows, tau, hi_freq)["psnr"]


def candidates(scenes: Dict[str, dict]) -> List[float]:
  """Thresholds worth trying: between consecutive criterion values seen in
  `scenes`, and beyond both ends."""
  values = sorted({r.get("score", r["criterion"]) for s in scenes.values() for r in s["grid"]})
  mids = [(a + b) / 2 for a, b in zip(values[:-1], values[1:])]
  return [values[0] * 0.5] + mids + [values[-1] * 1.5]


def choose(scenes: Dict[str, dict]) -> dict:
  """{'threshold', 'mean_regret'} minimising the mean regret over `scenes`
  ({name: {'grid': rows, 'hi_freq': f}})."""
  taus = candidates(scenes)
  mean = np.array([np.mean([regret(s["grid"], t, s["hi_freq"]) for s in scenes.values()])
                   for t in taus])
  best = np.flatnonzero(mean <= mean.min() + 1e-9)
  tau = float(np.median([taus[i] for i in best]))
  return {"threshold": tau,
          "mean_regret": float(np.mean([regret(s["grid"], tau, s["hi_freq"])
                                        for s in scenes.values()]))}


def leave_one_out(scenes: Dict[str, dict]) -> Dict[str, dict]:
  """For each scene: the threshold chosen on the others, the row it picks
  there, the best row, and the distance between them in dB."""
  out = {}
  for name, s in scenes.items():
    others = {k: v for k, v in scenes.items() if k != name}
    tau = choose(others)["threshold"]
    chosen = pick(s["grid"], tau, s["hi_freq"])
    best = max(s["grid"], key=lambda r: r["psnr"])
    out[name] = {"threshold": tau, "pick": (chosen["L"], chosen["scale"]),
                 "pick_psnr": chosen["psnr"], "best": (best["L"], best["scale"]),
                 "best_psnr": best["psnr"], "regret": best["psnr"] - chosen["psnr"]}
  return out
