"""A study's result files (experiments/bench/ablations.py writes them)."""
import json
import os


def read(results: str, study_name: str) -> dict:
  """{(scene, variant): [record, ...]} of a study's finished runs."""
  root = os.path.join(results, "ablations", study_name)
  out = {}
  if not os.path.isdir(root):
    return out
  for dirpath, _, files in os.walk(root):
    for f in sorted(files):
      if f.endswith(".json"):
        with open(os.path.join(dirpath, f)) as fh:
          r = json.load(fh)
        out.setdefault((r["scene"], r["variant"]), []).append(r)
  return out
