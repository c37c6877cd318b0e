"""The budget study page's candidate section: the largest budget's goals read
with a study variant in place of halo, on the scenes where the study's halo
is the suite's own run (adopted from it, with the suite's record's figures
today: the same resolved config), so the
variant differs from the suite's halo by its overrides alone. A candidate
default is shown beside the goals before it is adopted; it is not the
default, and the section says so.
"""
import glob
import json
import os

import numpy as np

from experiments.bench.report_common import BASELINE

METHOD = "halo"
# (study at the largest budget, its variant): the candidate now shown
CANDIDATE = ("hi_window_960", "samples_64_after_2000")


def _records(root, scene, variant) -> list:
  """The study's records of `variant` on `scene`, by seed."""
  out = []
  for path in sorted(glob.glob(os.path.join(root, scene, variant, "seed*.json"))):
    with open(path) as f:
      out.append(json.load(f))
  return out


def _seeds(records) -> list:
  """The records' seeds, sorted ([] where one lacks its seed)."""
  seeds = [r.get("seed") for r in records]
  return [] if None in seeds else sorted(seeds)


def _adopted_path(record) -> str:
  """The suite record a study record was adopted from ('' for none); an
  older record names it by a bare path."""
  source = record.get("adopted_from") or ""
  return source.get("path", "") if isinstance(source, dict) else source


def swapped(runs, results, suite="budget_960", candidate=CANDIDATE):
  """({scene: {method: [record]}} of `runs` with halo's records replaced by
  the candidate's where the study's halo on every seed is `suite`'s own run
  and the candidate has the same seeds; the scenes swapped)."""
  root = os.path.join(results, "ablations", candidate[0])
  out, done = dict(runs), []
  for scene, by in runs.items():
    mine, ref = _records(root, scene, candidate[1]), _records(root, scene, METHOD)
    seeds = _seeds(by.get(METHOD, []))
    if not seeds or _seeds(mine) != seeds:
      continue
    suite_psnr = {r["seed"]: r["psnr"] for r in by[METHOD]}
    # adopted from the suite's run, and that run is still the suite's record
    if _seeds(ref) != seeds or not all(_adopted_path(r).startswith(f"{suite}/")
                                       and r["psnr"] == suite_psnr[r["seed"]] for r in ref):
      continue
    out[scene] = dict(by, **{METHOD: mine})
    done.append(scene)
  return out, done


def lines(runs, results, goals_line, wanted: int, candidate=CANDIDATE) -> list:
  """The section: per swapped scene halo, the candidate and the baseline, the
  margins before and after, then goals_line(swapped runs, wanted)."""
  new, done = swapped(runs, results, candidate=candidate)
  if not done:
    return []
  mean = lambda rs: float(np.mean([r["psnr"] for r in rs]))  # noqa: E731
  rows = [f"| {s} ({len(new[s][METHOD])}) | {mean(runs[s][METHOD]):.2f} | "
          f"{mean(new[s][METHOD]):.2f} | {mean(runs[s][BASELINE]):.2f} | "
          f"{mean(runs[s][METHOD]) - mean(runs[s][BASELINE]):+.2f} | "
          f"{mean(new[s][METHOD]) - mean(runs[s][BASELINE]):+.2f} |"
          for s in done if BASELINE in runs[s]]
  study, variant = candidate
  return [f"### A candidate default: `{variant}`", "",
          f"Its runs from the study `{study}` "
          f"([page](ablation_{study}.md)) in place of halo's, on the scenes where that "
          "study's halo is this suite's own run, so the two differ by the variant's "
          "overrides alone (seeds in brackets). It is not HALO's default: the goals below "
          "are read with it, beside the goals above.", "",
          f"| scene | halo | `{variant}` | {BASELINE} | Δ | Δ, candidate |",
          "|---|---|---|---|---|---|", *rows, "",
          "With the candidate: " + goals_line(new, wanted), ""]
