"""Step-capped runs of every method on every scene kind, for refactors that
must not move a number.

A refactor of shared code is checked by running this before and after it and
comparing the two files: every logged loss and every held-out PSNR should
agree to the last digit, or (where the change reorders floating-point sums)
within --tolerance_db.

  python experiments/same_numbers.py --out=/tmp/before.json
  ... change the code ...
  python experiments/same_numbers.py --out=/tmp/after.json --compare=/tmp/before.json

The same runs fingerprint the code (halo_jax/bench/code_version.py): --record
stores each method's fingerprint, the hash of its runs' figures, in
results/fingerprints.json under the code tree of the checkout, and
--commit=SHA measures an earlier commit in a temporary git worktree:

  python experiments/same_numbers.py --out=/tmp/head.json --record
  python experiments/same_numbers.py --out=/tmp/old.json --record --commit=3dc7483

The runs use one thread on one core (set at the top of this script): XLA
splits its CPU reductions by thread count, and the last bits of a figure
would follow it.

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
import shutil
import subprocess
import sys
import tempfile

# One thread on one core, set before jax is imported: XLA's CPU backend splits
# reductions by its thread count, so the same code on 1 or 2 cores differs in
# the last bits, and a fingerprint must not depend on the machine's load.
if hasattr(os, "sched_setaffinity"):
  os.sched_setaffinity(0, {min(os.sched_getaffinity(0))})
os.environ["XLA_FLAGS"] = (os.environ.get("XLA_FLAGS", "")
                           + " --xla_cpu_multi_thread_eigen=false"
                           + " intra_op_parallelism_threads=1").strip()

from absl import app, flags  # noqa: E402

import halo_jax  # noqa: E402
from halo_jax import datasets, defaults, pipeline, protocol, provenance, runs  # noqa: E402

# This copy also runs in worktrees of older commits (--commit), whose suites
# are experiments/suites.py and which have no fingerprints to record.
if os.path.isdir(os.path.join(os.path.dirname(halo_jax.__file__), "bench")):
  from halo_jax.bench import code_version, suites  # noqa: E402
else:
  from experiments import suites  # noqa: E402
  code_version = None

try:  # the one loader; a worktree of a commit older than it has runs.load_config_as
  from halo_jax.configure import load as load_as_method  # noqa: E402
except ImportError:
  load_as_method = runs.load_config_as  # pylint: disable=no-member


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
flags.DEFINE_string("methods", "", "comma-separated methods to run ('': every method of each scene)")
flags.DEFINE_bool("record", False, "store each method's fingerprint in results/fingerprints.json "
                  "(refused from a checkout whose training code is modified)")
flags.DEFINE_string("commit", "", "measure this commit instead of the checkout: a temporary git "
                    "worktree of it runs this script")


# Fingerprinted beside the suite's methods: the authors' recipe (static scenes).
AUTHORS = ("halo_authors",)


def scene_list():
  """[(name, config spec, data folder, methods)] for the --scenes flag."""
  by_name = {s.name: s for s in suites.CPU.scenes}
  out = []
  wanted = [m for m in FLAGS.methods.split(",") if m]
  for name in FLAGS.scenes.split(","):
    if name == "default":
      out.append((name, "configs/default.py", "", tuple(suites.ALL_METHODS) + AUTHORS))
    else:
      s = by_name[name]
      static = not name.startswith("dnerf")
      out.append((name, s.config, s.needs, tuple(s.methods) + (AUTHORS if static else ())))
  return [(n, spec, needs, tuple(m for m in ms if not wanted or m in wanted))
          for n, spec, needs, ms in out]


def step_capped(config, steps):
  """config trained for `steps` steps a stage, every step logged, no budget."""
  c = protocol.steps(copy.deepcopy(config))
  c.tune.lo_steps = steps
  c.eval.lpips = False
  c.eval.save_images = False
  c.eval.curve_views = 1
  c.eval.flicker_frames = 3  # dynamic scenes' flicker video (its least): not compared here
  for name in ("lo", "ray", "hi"):
    c[name].update(steps=steps, min_steps=0, log_every=1, eval_every=0,
                   checkpoint_every=10 * steps)
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
  c = step_capped(load_as_method(spec, method), FLAGS.steps)
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


def measure_commit(commit: str) -> dict:
  """Runs this script's runs at `commit` in a temporary worktree (this copy of
  the script, that commit's library) and returns its --out figures."""
  repo = code_version.REPO
  with tempfile.TemporaryDirectory(prefix="same_numbers_wt_") as tmp:
    tree = os.path.join(tmp, "tree")
    subprocess.run(["git", "-C", repo, "worktree", "add", "--detach", tree, commit], check=True,
                   capture_output=True)
    try:
      shutil.copy(__file__, os.path.join(tree, "experiments", "same_numbers.py"))
      out = os.path.join(tmp, "figures.json")
      if os.path.exists(FLAGS.out):
        shutil.copy(FLAGS.out, out)
      args = [f"--out={out}", f"--steps={FLAGS.steps}", f"--views={FLAGS.views}",
              f"--scenes={FLAGS.scenes}", f"--methods={FLAGS.methods}", f"--shard={FLAGS.shard}"]
      # the worktree's own package first, before the installed one
      env = dict(os.environ, PYTHONPATH=tree)
      subprocess.run([sys.executable, os.path.join(tree, "experiments", "same_numbers.py"), *args],
                     check=True, cwd=tree, env=env)
      shutil.copy(out, FLAGS.out)
      with open(out) as f:
        return json.load(f)
    finally:
      subprocess.run(["git", "-C", repo, "worktree", "remove", "--force", tree],
                     capture_output=True)


def main(argv):
  del argv
  if FLAGS.commit:
    sha = subprocess.run(["git", "-C", code_version.REPO, "rev-parse", FLAGS.commit],
                         capture_output=True, text=True, check=True).stdout.strip()
    results = measure_commit(sha)
    if FLAGS.record:
      print(code_version.record(sha, results, FLAGS.steps, FLAGS.views))
    return
  if FLAGS.record:
    state = provenance.git_state()
    if state["code_dirty"] or not state["code_tree"]:
      sys.exit("error: --record needs a checkout whose training code "
               f"({', '.join(provenance.TRAINING_CODE)}) is committed and unmodified")
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
  if FLAGS.record:
    print(code_version.record(state["commit"], results, FLAGS.steps, FLAGS.views))


if __name__ == "__main__":
  flags.mark_flag_as_required("out")
  app.run(main)
