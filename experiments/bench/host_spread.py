"""The host spread of the 960-s study: how far a run's figure moves when the
same run (scene, method, seed 0, the same steps) is trained again in a later
session, on whatever host that session gets.

The budget protocol fixes the steps, so what moves a rerun is the host's
floating-point path (its CPU's vector code, the library build), not its
speed. A rerun is a suite run trained again:
  results/<suite>/rerun/<scene>/<method>/seed0.json
(experiments/bench/benchmark.py with --results pointing elsewhere, then
copied there; report.py leaves the 'rerun' folders out of the suite pages).
A scene kind's spread is the largest move of the halo - nerf_tuned margin
over its rerun pairs; a margin no larger than its kind's spread falls inside
it, so its sign is not measured.
"""
import json
import os

import numpy as np

MODE = "rerun"


def reruns(results: str, suite: str) -> dict:
  """{scene: {method: record}} of `suite`'s reruns under `results`."""
  root = os.path.join(results, suite, MODE)
  out = {}
  if not os.path.isdir(root):
    return out
  for scene in sorted(os.listdir(root)):
    for method in sorted(os.listdir(os.path.join(root, scene))):
      for f in sorted(os.listdir(os.path.join(root, scene, method))):
        if f.endswith(".json"):
          with open(os.path.join(root, scene, method, f)) as fh:
            out.setdefault(scene, {})[method] = json.load(fh)
  return out


def pairs(runs: dict, again: dict, methods=("halo", "nerf_tuned")) -> dict:
  """{scene: {'record': {method: psnr}, 'rerun': {method: psnr}, 'moved':
  margin's move (rerun - record), 'kind'}} for each scene whose reruns of
  both `methods` have a record of the same seed in `runs` ({scene: {method:
  [record]}})."""
  out = {}
  for scene, by in again.items():
    first = {}
    for m in methods:
      rerun = by.get(m)
      match = [r for r in runs.get(scene, {}).get(m, [])
               if rerun is not None and r.get("seed") == rerun.get("seed")]
      if match:
        first[m] = match[0]
    if len(first) < len(methods):
      continue
    rec = {m: float(first[m]["psnr"]) for m in methods}
    new = {m: float(by[m]["psnr"]) for m in methods}
    a, b = methods
    out[scene] = {"record": rec, "rerun": new,
                  "moved": (new[a] - new[b]) - (rec[a] - rec[b]),
                  "seed": by[a].get("seed"), "config": first[a]["config"],
                  "when": {m: [(first[m].get("provenance") or {}).get("time_utc", "?")[:10],
                               (by[m].get("provenance") or {}).get("time_utc", "?")[:10]]
                           for m in methods}}
  return out


def by_kind(found: dict, kind_of) -> dict:
  """{kind: spread}: the largest |margin move| over each kind's pairs."""
  out = {}
  for p in found.values():
    k = kind_of(p["config"])
    out[k] = max(out.get(k, 0.0), abs(p["moved"]))
  return out


def lines(found: dict, kind_of, budget_s: float, methods=("halo", "nerf_tuned")) -> list:
  """The page's section: each rerun pair beside its record, and each
  kind's spread."""
  if not found:
    return []
  a, b = methods
  rows = [f"| {kind_of(p['config'])} | {s} | {p['record'][a]:.2f} → {p['rerun'][a]:.2f} | "
          f"{p['record'][b]:.2f} → {p['rerun'][b]:.2f} | "
          f"{p['record'][a] - p['record'][b]:+.2f} → {p['rerun'][a] - p['rerun'][b]:+.2f} | "
          f"{p['moved']:+.2f} | " + ", ".join(f"{m} {' → '.join(d)}" for m, d in p["when"].items())
          + " |" for s, p in sorted(found.items(), key=lambda kv: kind_of(kv[1]["config"]))]
  moves = np.abs([p["moved"] for p in found.values()])
  return [f"### Host spread at {budget_s:g} s", "",
          f"The seed-{next(iter(found.values()))['seed']} pair of one scene of each kind, "
          "trained again in a later session on whatever host it got (the same steps: the "
          "budget fixes them), against the suite's record (`results/budget_960/rerun/`, "
          "experiments/bench/host_spread.py). A kind's spread is its pair's move of the "
          "margin; the table above marks a margin no larger than its kind's spread.", "",
          f"| kind | scene | {a}: record → rerun | {b}: record → rerun | Δ: record → rerun | "
          "margin moved | dates (record → rerun) |", "|---|---|---|---|---|---|---|", *rows, "",
          f"Largest move of a margin: {moves.max():.2f} dB; median {np.median(moves):.2f} dB "
          f"over {len(moves)} pairs.", ""]
