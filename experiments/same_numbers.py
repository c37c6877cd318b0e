"""Step-capped runs of every method on every scene kind, for refactors that
must not move a number.

A refactor of shared code is checked by running this before and after it and
comparing the two files: every logged loss and every held-out PSNR should
agree to the last digit, or (where the change reorders floating-point sums)
within --tolerance_db.

  python experiments/same_numbers.py --out=/tmp/before.json
  ... change the code ...
  python experiments/same_numbers.py --out=/tmp/after.json --compare=/tmp/before.json

Each run trains every stage of its method for --steps steps (no time budget,
so the machine's speed does not change what is trained), logs every step and
scores the final stage on the first --views held-out views. Scenes whose data
folder is absent under $HALO_DATA are skipped and say so. Runs are
independent, so --shard=i/n splits them over processes (one per core).
"""
import copy
import dataclasses
import json
import os
import sys
import tempfile

from absl import app, flags

sys.path.insert(0, os.path.join(os.path.dirname(__file__), ".."))
from experiments import suites  # noqa: E402
from halo_jax import datasets, defaults, pipeline, runs  # noqa: E402

FLAGS = flags.FLAGS
flags.DEFINE_string("out", None, "JSON file the figures are written to (after each run; "
                    "runs it already holds are not run again).")
flags.DEFINE_string("compare", "", "an earlier --out file: report what differs from it")
flags.DEFINE_integer("steps", 3, "training steps of every stage")
flags.DEFINE_integer("views", 1, "held-out views scored at the end")
flags.DEFINE_string("scenes", "default,lego_8view,dnerf_hook,fern_4view,knights",
                    "scenes: 'default' (the built-in job) and names of the CPU suite's scenes")
flags.DEFINE_string("shard", "0/1", "i/n: run every n-th of the runs, starting at the i-th")
flags.DEFINE_float("tolerance_db", 0.0, "largest PSNR difference reported as equal")


def scene_list():
  """[(name, config spec, data folder, methods)] for the --scenes flag."""
  by_name = {s.name: s for s in suites.CPU.scenes}
  out = []
  for name in FLAGS.scenes.split(","):
    if name == "default":
      out.append((name, "configs/default.py", "", suites.ALL_METHODS))
    else:
      s = by_name[name]
      out.append((name, s.config, s.needs, s.methods))
  return out


def step_capped(config, steps):
  """config trained for `steps` steps a stage, every step logged, no budget."""
  c = copy.deepcopy(config)
  c.budget_s = 0.0
  c.tune.lo_steps = steps
  c.eval.lpips = False
  c.eval.save_images = False
  c.eval.curve_views = 1
  c.eval.flicker_frames = 3  # dynamic scenes' flicker video (its least): not compared here
  for name in ("lo", "ray", "hi"):
    c[name].update(steps=steps, min_steps=0, log_every=1, eval_every=0, eval_every_s=0.0,
                   checkpoint_every=10 * steps)
    c[name].max_seconds = 0.0
  return c


def first_views(views, k):
  """The first k of a Views-like dataclass (every per-view field cut)."""
  n = len(views.names)
  cut = {f.name: getattr(views, f.name)[:k] for f in dataclasses.fields(views)
         if getattr(views, f.name) is not None and hasattr(getattr(views, f.name), "__len__")
         and len(getattr(views, f.name)) == n}
  return dataclasses.replace(views, **cut)


def run_one(spec, method, workdir):
  """{'losses': {stage: [[step, loss], ...]}, 'psnr': [per held-out view]}."""
  c = step_capped(runs.load_config_as(spec, method), FLAGS.steps)
  ds = datasets.load(c.data, workdir)
  ds = dataclasses.replace(ds, test=first_views(ds.test, FLAGS.views))
  infos = pipeline.run(c, workdir, ds)
  losses = {}
  with open(os.path.join(workdir, "metrics.jsonl")) as f:
    for line in f:
      r = json.loads(line)
      if "loss" in r and not r.get("heldout"):
        losses.setdefault(r["stage"], []).append([r["step"], r["loss"]])
  per_view = infos[c.final_stage]["eval"]["per_view"]
  return {"losses": losses, "psnr": [per_view[n]["psnr"] for n in sorted(per_view)]}


def differences(before, after, tol):
  """Lines naming each run and figure that differs (beyond tol dB for PSNR)."""
  lines = []
  for key in sorted(set(before) | set(after)):
    a, b = before.get(key), after.get(key)
    if a is None or b is None:
      lines.append(f"{key}: only in {'after' if a is None else 'before'}")
      continue
    if a["losses"] != b["losses"]:
      lines.append(f"{key}: losses differ: {a['losses']} -> {b['losses']}")
    worst = max((abs(x - y) for x, y in zip(a["psnr"], b["psnr"])), default=0.0)
    if len(a["psnr"]) != len(b["psnr"]) or worst > tol:
      lines.append(f"{key}: held-out PSNR {a['psnr']} -> {b['psnr']} ({worst:.2e} dB)")
  return lines


def main(argv):
  del argv
  data_root = os.environ.get("HALO_DATA", defaults.data_root(""))
  shard, num_shards = (int(x) for x in FLAGS.shard.split("/"))
  todo = [(n, spec, m) for n, spec, needs, methods in scene_list() for m in methods
          if not needs or os.path.isdir(os.path.join(data_root, needs))]
  for n, _, needs, _ in scene_list():
    if needs and not os.path.isdir(os.path.join(data_root, needs)):
      print(f"skipped {n}: no {os.path.join(data_root, needs)}")
  results = {}
  if os.path.exists(FLAGS.out):  # a stopped launch: keep the runs it finished
    with open(FLAGS.out) as f:
      results = json.load(f)
  for i, (name, spec, method) in enumerate(todo):
    key = f"{name}/{method}"
    if i % num_shards != shard or key in results:
      continue
    with tempfile.TemporaryDirectory(prefix="same_numbers_") as workdir:
      results[key] = run_one(spec, method, workdir)
    print(f"{key}: psnr {[round(p, 4) for p in results[key]['psnr']]}", flush=True)
    with open(FLAGS.out, "w") as f:
      json.dump(results, f, indent=1)
  if FLAGS.compare:
    with open(FLAGS.compare) as f:
      before = json.load(f)
    before = {k: v for k, v in before.items() if k in results}
    lines = differences(before, results, FLAGS.tolerance_db)
    print("\n".join(lines) if lines else f"same numbers on all {len(results)} runs")
    if lines:
      sys.exit(1)


if __name__ == "__main__":
  flags.mark_flag_as_required("out")
  app.run(main)
