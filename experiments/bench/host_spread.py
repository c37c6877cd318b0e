"""The host spread of the 960-s study: how far a run's figure moves when the
same run (scene, method, seed 0, the same steps) is trained again in a later
session, on whatever host that session gets.

The budget protocol fixes the steps, so what moves a rerun is the host's
floating-point path (its CPU's vector code, the library build), not its
speed. A rerun is a suite run trained again:
  results/<suite>/rerun/<scene>/<method>/seed0.json, or seed0@<host>.json
for a scene's rerun on another host (experiments/bench/benchmark.py with
--results pointing elsewhere, then copied there; report.py leaves the
'rerun' folders out of the suite pages). The two methods' files of the
same name make a pair.
A scene kind's spread is the largest move of the halo - nerf_tuned margin
over its rerun pairs; a margin no larger than its kind's spread falls inside
it, so its sign is not measured.
"""
import json
import os

import numpy as np

from halo_jax import sampler_switch

MODE = "rerun"


def reruns(results: str, suite: str) -> dict:
  """{label: {method: record}} of `suite`'s reruns under `results`: the
  label is the scene for `seed0.json`, '<scene> @<host>' for
  `seed0@<host>.json`."""
  root = os.path.join(results, suite, MODE)
  out = {}
  if not os.path.isdir(root):
    return out
  for scene in sorted(os.listdir(root)):
    for method in sorted(os.listdir(os.path.join(root, scene))):
      for f in sorted(os.listdir(os.path.join(root, scene, method))):
        if f.endswith(".json"):
          host = f[:-len(".json")].partition("@")[2]
          with open(os.path.join(root, scene, method, f)) as fh:
            out.setdefault(f"{scene} @{host}" if host else scene, {})[method] = json.load(fh)
  return out


def _date(record) -> str:
  return (record.get("provenance") or {}).get("time_utc", "?")[:10]


def _cpu(record) -> str:
  return ((record.get("provenance") or {}).get("cpu") or {}).get("model", "?")


def _pair(first: dict, again: dict, dates: dict, seed, methods, host="not recorded") -> dict:
  """One pair's entry: `first` {method: suite record}, `again` {method: the
  rerun's PSNR}, `dates` {method: the rerun's date}, `host` the rerun's CPU."""
  a, b = methods
  rec = {m: float(first[m]["psnr"]) for m in methods}
  new = {m: float(again[m]) for m in methods}
  return {"record": rec, "rerun": new, "moved": (new[a] - new[b]) - (rec[a] - rec[b]),
          "seed": seed, "config": first[a]["config"], "host": host,
          "when": {m: [_date(first[m]), dates[m]] for m in methods}}


def _same_seed(runs, scene, method, seed):
  """The suite record of `scene`, `method` and `seed` in `runs`, or None."""
  return next((r for r in runs.get(scene, {}).get(method, []) if r.get("seed") == seed), None)


def _same_run(record: dict, rerun: dict) -> bool:
  """Whether a rerun trained the record's run: the same resolved config (a
  rerun made before a default changed is another run, not host noise)."""
  from experiments.bench import adopt  # pylint: disable=import-outside-toplevel  (it reads runs)
  if "resolved_config" not in record or "resolved_config" not in rerun:
    return True  # older than configs in records: the fingerprint vouched for them
  return adopt.same_resolved(adopt.run_config(rerun), adopt.run_config(record))


def pairs(runs: dict, again: dict, methods=("halo", "nerf_tuned")) -> dict:
  """{scene: {'record': {method: psnr}, 'rerun': {method: psnr}, 'moved':
  margin's move (rerun - record), 'seed', 'config', 'when'}} for each scene
  whose reruns of both `methods` are runs of a record of the same seed in
  `runs` ({scene: {method: [record]}}), config for config; keyed by
  reruns()' labels."""
  out = {}
  for label, by in again.items():
    scene = label.partition(" @")[0]
    if not all(m in by for m in methods):
      continue
    first = {m: _same_seed(runs, scene, m, by[m].get("seed")) for m in methods}
    if all(first.values()) and all(_same_run(first[m], by[m]) for m in methods):
      out[label] = _pair(first, {m: by[m]["psnr"] for m in methods},
                         {m: _date(by[m]) for m in methods}, by[methods[0]].get("seed"), methods,
                         " / ".join(sorted({_cpu(by[m]) for m in methods})))
  return out


def probe_pairs(runs: dict, probes: list, same_code, methods=("halo", "nerf_tuned")) -> dict:
  """pairs()' entries from runs trained again for the budget probes in
  earlier sessions (budget_probe.py: each probe file's `record_psnr` and
  `runs`), where both methods' probed runs are of the same seed as a suite
  record, of code that computes what the record's does (`same_code(record,
  probed run's git) -> bool`: the same measured fingerprint), and at least
  one was trained again (another commit than its record's)."""
  out = {}
  for p in probes:
    scene, seed, mine, git = p.get("scene"), p.get("seed"), p.get("record_psnr", {}), p.get("runs", {})
    if not all(m in mine for m in methods):
      continue
    first = {m: _same_seed(runs, scene, m, seed) for m in methods}
    if not all(first.values()) or not all(same_code(first[m], git.get(m, {})) for m in methods):
      continue
    if p.get("hi_sampler") and p["hi_sampler"] != _scored_sampler(first[methods[0]]):
      continue  # the probed run sampled otherwise: another config, not host noise
    if all(git.get(m, {}).get("commit") == (first[m].get("provenance") or {}).get(
        "git", {}).get("commit") for m in methods):
      continue  # the record's own runs, probed where they were trained
    out[f"{scene} (probe)"] = _pair(first, mine, {m: _date(p) for m in methods}, seed, methods)
  return out


def _scored_sampler(record: dict):
  """{'kind', 'num_samples'} of the Hi sampler a record's run was scored
  with (past its sampler switch, the switched one); None where the record
  has no resolved config."""
  hi = (record.get("resolved_config") or {}).get("hi")
  if not hi:
    return None
  sampler = hi["sampler"]
  if sampler_switch.after(hi, record["stages"]["hi"]["step"]):
    return {"kind": sampler.get("switch_kind") or sampler["kind"],
            "num_samples": sampler["switch_samples"]}
  return {"kind": sampler["kind"], "num_samples": sampler["num_samples"]}


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
          + f" | {p['host']} |"
          for s, p in sorted(found.items(), key=lambda kv: kind_of(kv[1]["config"]))]
  moves = np.abs([p["moved"] for p in found.values()])
  return [f"### Host spread at {budget_s:g} s", "",
          "The seed-0 pair of one scene of each kind, trained again in a later session on "
          "whatever host it got (the same steps: the budget fixes them; `@host` names a "
          "further rerun on another), against the suite's "
          "record (`results/budget_960/rerun/`, experiments/bench/host_spread.py); and, "
          "marked `(probe)`, the pairs trained again for the budget probes in earlier "
          "sessions by code of the same measured fingerprint. A kind's spread is the largest "
          "move of a margin among its pairs; the table above marks a margin no larger than "
          "its kind's spread.", "",
          f"| kind | scene | {a}: record → rerun | {b}: record → rerun | Δ: record → rerun | "
          "margin moved | dates (record → rerun) | rerun's CPU |",
          "|---|---|---|---|---|---|---|---|", *rows, "",
          f"Largest move of a margin: {moves.max():.2f} dB; median {np.median(moves):.2f} dB "
          f"over {len(moves)} pairs.", ""]
