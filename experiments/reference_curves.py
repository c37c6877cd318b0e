"""Puts the held-out curves of finished 'budget' records on the reference clock.

Records written before held-out points carried `reference_s` (4183f6e) keep
their curve against this machine's training seconds, though the points were
placed on the reference clock. Each point's step is in the run's workdir
(metrics.jsonl), and the record's protocol holds each stage's reference step
and set-up seconds, so its reference time is

  offset(stage) + setup_s(stage) + step * step_s(stage),

offset being the reference seconds of the stages before it. This rewrites
`curve` in each such record (from its workdir under --scratch) and marks it
`curve_clock: "reference"`; records already marked, or whose workdir is
gone, are left as they are and listed.

  python -m experiments.reference_curves --results=results/cpu/budget --scratch=/tmp/halo_bench
"""
import glob
import json
import os

from absl import app, flags

FLAGS = flags.FLAGS
flags.DEFINE_string("results", "results/cpu/budget", "folder of <scene>/<method>/seed<k>.json")
flags.DEFINE_string("scratch", "/tmp/halo_bench", "the benchmark's --scratch")


def reference_times(protocol: dict) -> dict:
  """{stage: (offset_s + setup_s, step_s)} from a record's protocol summary."""
  out, spent = {}, 0.0
  for name, s in protocol["stages"].items():
    out[name] = (spent + s["setup_s"], s["step_s"])
    spent += s["setup_s"] + s["steps"] * s["step_s"]
  return out


def curve_of(metrics_path: str, clock: dict) -> list:
  """[[reference s, held-out PSNR]] of a run's log (the last record of each
  stage and step, as runs.read_curve)."""
  points = {}
  with open(metrics_path) as f:
    for line in f:
      r = json.loads(line)
      if r.get("heldout"):
        start, step_s = clock[r["stage"]]
        points[(r["stage"], r["step"])] = [start + r["step"] * step_s, r["psnr"]]
  return sorted(points.values())


def main(argv):
  del argv
  suite_dir = os.path.abspath(FLAGS.results)
  for path in sorted(glob.glob(os.path.join(suite_dir, "*", "*", "seed*.json"))):
    with open(path) as f:
      rec = json.load(f)
    scene, method, seed = path.split(os.sep)[-3:]
    tag = f"{scene}/{method}/{seed[:-5]}"
    proto = rec.get("protocol") or {}
    if rec.get("curve_clock") == "reference" or proto.get("kind") != "budget" \
        or proto.get("measured"):
      print(f"kept      {tag}")
      continue
    suite, mode = suite_dir.split(os.sep)[-2:]
    metrics = os.path.join(FLAGS.scratch, suite, mode, scene, method, seed[:-5], "metrics.jsonl")
    if not os.path.exists(metrics):
      print(f"no log    {tag}: {metrics}")
      continue
    rec["curve"] = curve_of(metrics, reference_times(proto))
    rec["curve_clock"] = "reference"
    with open(path, "w") as f:
      json.dump(rec, f, indent=1)
    print(f"rewritten {tag}: {len(rec['curve'])} points")


if __name__ == "__main__":
  app.run(main)
