"""A study's result files (experiments/bench/ablations.py writes them)."""
import json
import os

# What a study's record adds to its run's record: the fields that name the
# study's run, and the stops it set (a suite run that adopts it drops them).
FIELDS = ("study", "variant", "overrides", "split", "stop_at_step")


def study_fields(study_name: str, variant, c, stages) -> dict:
  """FIELDS of `variant`'s run in `study_name`, with config `c`, whose record
  has `stages`."""
  out = dict(study=study_name, variant=variant.name,
             overrides=[list(o) for o in variant.overrides], split=c.data.test_split,
             stop_at_step={n: c[n].stop_at_step for n in stages})
  return out


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
