"""Fingerprint runs of every method on every scene kind, for refactors that
must not move a number, and the code's fingerprint.

Each run is the fingerprint run of experiments/bench/fingerprint.py: the CPU
suite's run of a scene and method at shrunk sizes, every stage trained past
every step switch the suite's run crosses (the crop, the foreground start,
the collapse check, L_empty's start, the light field's window), under the
'budget' protocol with its fronts and held-out curve, scored on the first
--views held-out views. A refactor of shared code is checked by running this
before and after it and comparing the two files: every logged loss, every
held-out figure and every step count should agree to the last digit, or
(where the change reorders floating-point sums) within --tolerance_db.

  python -m experiments.same_numbers --out=/tmp/before.json
  ... change the code ...
  python -m experiments.same_numbers --out=/tmp/after.json --compare=/tmp/before.json

The same runs fingerprint the code (experiments/bench/code_version.py): --record
stores each method's fingerprint, the hash of its runs' figures, in
results/fingerprints.json under the code tree of the checkout, and
--commit=SHA measures an earlier commit in a temporary git worktree with
that commit's own script, fingerprint runs and library (commits from the
benchmark's move to experiments/bench on; an older one is measured by running
its own script in a worktree of it with --record there):

  python -m experiments.same_numbers --out=/tmp/head.json --record
  python -m experiments.same_numbers --out=/tmp/old.json --record --commit=1f8ac84

--study=NAME runs the same fingerprint runs for a time study (studies.py) at
its budget: each variant and what it is checked against (the study's
reference, or the plain baseline for the baseline's twins) on each of its
scenes, each with its own overrides, and writes results/identity/NAME.json
(experiments/bench/identity.py): whether each variant is the reference, to
the last digit, at that budget, so its rule judges it only where it differs:

  python -m experiments.same_numbers --study=hi_window_60 --variants=dense_eval_2000 \
      --out=/tmp/id60.json --procs=2

The runs use one thread on one core (set at the top of this script): XLA
splits its CPU reductions by thread count, and the last bits of a figure
would follow it. Scenes whose data folder is absent under $HALO_DATA are
skipped and say so. Runs are independent, so --shard=i/n splits them over
processes (one per core).
"""
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
  # --procs's shards inherit the launch's cores and take the i-th of them
  os.environ.setdefault("SAME_NUMBERS_CORES",
                        ",".join(map(str, sorted(os.sched_getaffinity(0)))))
  _CORES = [int(c) for c in os.environ["SAME_NUMBERS_CORES"].split(",")]
  os.sched_setaffinity(0, {_CORES[int(os.environ.get("SAME_NUMBERS_CORE", 0)) % len(_CORES)]})
os.environ["XLA_FLAGS"] = (os.environ.get("XLA_FLAGS", "")
                           + " --xla_cpu_multi_thread_eigen=false"
                           + " intra_op_parallelism_threads=1").strip()

from absl import app, flags, logging  # noqa: E402

from halo_jax import defaults, progress  # noqa: E402
from experiments.bench import (ablations, code_version, fingerprint, git_state, identity,  # noqa: E402
                               suites)
from experiments.bench.studies import STUDIES  # noqa: E402

FLAGS = flags.FLAGS
flags.DEFINE_string("out", None, "JSON file the figures are written to (after each run; "
                    "runs it already holds are not run again).")
flags.DEFINE_string("compare", "", "an earlier --out file: report what differs from it")
flags.DEFINE_integer("views", 1, "held-out views scored at the end")
flags.DEFINE_string("scenes", "lattice,lego_8view,dnerf_hook,fern_4view,knights",
                    "the CPU suite's scenes to run (one of each kind by default)")
flags.DEFINE_string("shard", "0/1", "i/n: run every n-th of the runs, starting at the i-th")
flags.DEFINE_integer("procs", 1, "processes, one per core, each running a shard")
flags.DEFINE_float("tolerance_db", 0.0, "largest PSNR difference reported as equal")
flags.DEFINE_string("methods", "", "comma-separated methods to run ('': every method of each scene)")
flags.DEFINE_bool("record", False, "store each method's fingerprint in results/fingerprints.json "
                  "(refused from a checkout whose training code is modified)")
flags.DEFINE_enum("study", "", [""] + sorted(STUDIES), "a time study: fingerprint its "
                  "variants and their references on its scenes, and write whether each is "
                  "identical at the study's budget (results/identity/)")
flags.DEFINE_string("variants", "", "with --study: the variants to check (comma-separated; "
                    "'': every variant with a reference to check it against)")
flags.DEFINE_string("commit", "", "measure this commit instead of the checkout: a temporary git "
                    "worktree of it runs this script")


# Fingerprinted beside the suite's methods: the authors' recipe (static scenes).
AUTHORS = ("halo_authors",)


def scene_list():
  """[(scene, methods)] for the --scenes and --methods flags."""
  by_name = {s.name: s for s in suites.CPU.scenes}
  wanted = [m for m in FLAGS.methods.split(",") if m]
  out = []
  for name in FLAGS.scenes.split(","):
    s = by_name[name]
    methods = tuple(s.methods) + (AUTHORS if s.config.split(":")[0] != "configs/dnerf.py"
                                  else ())
    out.append((s, tuple(m for m in methods if not wanted or m in wanted)))
  return out


def planned(data_root: str):
  """([(key, scene, method, terms, overrides)], [missing scene's line]): the
  fingerprint runs to make, those of scenes whose data is under data_root.
  With --study: each variant and what it is checked against on each of its
  scenes (identity.runs), on its terms; else each scene's methods on the CPU
  suite's."""
  if FLAGS.study:
    study = STUDIES[FLAGS.study]
    on = ablations.terms(study)
    wanted = [(f"{s.name}/{v.name}", s, v.method, on, ablations.run_overrides(study, v))
              for s, v in identity.runs(study, [n for n in FLAGS.variants.split(",") if n])]
  else:
    wanted = [(f"{s.name}/{m}", s, m, suites.CPU, ()) for s, ms in scene_list() for m in ms]
  has = lambda s: not s.needs or os.path.isdir(os.path.join(data_root, s.needs))  # noqa: E731
  missing = sorted({f"{s.name} (no {os.path.join(data_root, s.needs)})"
                    for _, s, *_ in wanted if not has(s)})
  return [w for w in wanted if has(w[1])], missing


def differences(before, after, tol):
  """Lines naming each run and figure that differs (beyond tol dB for PSNR)."""
  lines = []
  for key in sorted(set(before) | set(after)):
    a, b = before.get(key), after.get(key)
    if a is None or b is None:
      lines.append(f"{key}: only in {'after' if a is None else 'before'}")
      continue
    for field in sorted(set(a) | set(b)):
      if field == "psnr":
        worst = max((abs(x - y) for x, y in zip(a["psnr"], b["psnr"])), default=0.0)
        if len(a["psnr"]) != len(b["psnr"]) or worst > tol:
          lines.append(f"{key}: held-out PSNR {a['psnr']} -> {b['psnr']} ({worst:.2e} dB)")
      elif a.get(field) != b.get(field):
        lines.append(f"{key}: {field} differ: {a.get(field)} -> {b.get(field)}")
  return lines


def measure_commit(commit: str) -> dict:
  """Runs `commit`'s own same_numbers.py in a temporary worktree of it (its
  fingerprint runs and library: the fingerprint run is part of the code a
  record names) and returns its --out figures."""
  repo = code_version.REPO
  with tempfile.TemporaryDirectory(prefix="same_numbers_wt_") as tmp:
    tree = os.path.join(tmp, "tree")
    subprocess.run(["git", "-C", repo, "worktree", "add", "--detach", tree, commit], check=True,
                   capture_output=True)
    try:
      if not os.path.exists(os.path.join(tree, "experiments", "bench", "fingerprint.py")):
        raise SystemExit(f"{commit[:7]} predates experiments/bench: run its own "
                         "experiments/same_numbers.py in a worktree of it")
      out = os.path.join(tmp, "figures.json")
      if os.path.exists(FLAGS.out):
        shutil.copy(FLAGS.out, out)
      args = [f"--out={out}", f"--views={FLAGS.views}", f"--scenes={FLAGS.scenes}",
              f"--methods={FLAGS.methods}", f"--procs={FLAGS.procs}"]
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


def figures_only(results: dict) -> dict:
  """The runs' figures without the code tree each was made at (what a
  fingerprint hashes is the figures; which code made them is the record's)."""
  return {k: {f: x for f, x in v.items() if f != "code_tree"} for k, v in results.items()}


def run_shards() -> dict:
  """Runs --procs copies of this script, shard i pinned to the i-th allowed
  core, into <out>.<i>; returns their figures merged."""
  procs = []
  for i in range(FLAGS.procs):
    args = [a for a in sys.argv[1:] if not a.startswith(("--procs", "--shard", "--record",
                                                         "--compare", "--out"))]
    env = dict(os.environ, SAME_NUMBERS_CORE=str(i))
    procs.append(subprocess.Popen([sys.executable, "-m", "experiments.same_numbers",
                                   f"--out={FLAGS.out}.{i}", f"--shard={i}/{FLAGS.procs}", *args],
                                  env=env, cwd=code_version.REPO))
  if any(p.wait() for p in procs):
    sys.exit("error: a shard failed (its output is above); rerun to resume it")
  results = {}
  for i in range(FLAGS.procs):
    with open(f"{FLAGS.out}.{i}") as f:
      results.update(json.load(f))
  return results


def main(argv):
  del argv
  logging.set_verbosity(logging.WARNING)
  if FLAGS.commit:
    sha = subprocess.run(["git", "-C", code_version.REPO, "rev-parse", FLAGS.commit],
                         capture_output=True, text=True, check=True).stdout.strip()
    results = figures_only(measure_commit(sha))
    if FLAGS.record:
      print(code_version.record(sha, results, FLAGS.views))
    return
  if FLAGS.record:
    state = git_state.git_state()
    if state["code_dirty"] or not state["code_tree"]:
      sys.exit("error: --record needs a checkout whose training code "
               f"({', '.join(git_state.TRAINING_CODE)}) is committed and unmodified")
  if FLAGS.study and (FLAGS.record or FLAGS.commit):
    sys.exit("error: --study checks a study's variants on this checkout; it records no "
             "fingerprint and measures no other commit")
  if FLAGS.study and STUDIES[FLAGS.study].budget != "time":
    sys.exit(f"error: --study={FLAGS.study}: a study at matched steps has no budget to be "
             "identical at")
  data_root = os.environ.get("HALO_DATA", defaults.data_root(""))
  try:
    todo, missing = planned(data_root)
  except ValueError as e:
    sys.exit(f"error: --variants: {e}")
  if missing and FLAGS.record:  # a fingerprint covers every scene kind, or is not recorded
    sys.exit(f"error: --record needs every scene's data; missing: {', '.join(missing)} "
             "(set HALO_DATA)")
  for line in missing:
    print(f"skipped {line}")
  results = {}
  # a stopped launch's runs are kept, but only those of this very code: a file
  # from another commit (or a modified tree) would lend its figures to this one
  git = git_state.git_state()
  tree = None if git["code_dirty"] else git["code_tree"]
  if os.path.exists(FLAGS.out):
    with open(FLAGS.out) as f:
      held = json.load(f)
    results = {k: v for k, v in held.items() if tree and v.get("code_tree") == tree}
    if len(results) < len(held):
      print(f"{FLAGS.out}: {len(held) - len(results)} run(s) of other code not reused")
  if FLAGS.procs > 1:
    results.update(run_shards())
  else:
    shard, num_shards = (int(x) for x in FLAGS.shard.split("/"))
    mine = [run for i, run in enumerate(todo) if i % num_shards == shard and run[0] not in results]
    for key, scene, method, on, overrides in progress.steps(mine, "runs", "fingerprint runs"):
      with tempfile.TemporaryDirectory(prefix="same_numbers_") as workdir:
        results[key] = dict(fingerprint.run(scene, method, workdir, FLAGS.views, on, overrides),
                            code_tree=tree)
      r = results[key]
      print(f"{key}: steps {r['steps']}, psnr {[round(p, 4) for p in r['psnr']]}"
            + (f", collapsed at {r['collapsed']}" if r["collapsed"] else ""), flush=True)
      with open(FLAGS.out, "w") as f:
        json.dump(results, f, indent=1)
  with open(FLAGS.out, "w") as f:
    json.dump(results, f, indent=1)
  results = figures_only(results)
  if FLAGS.compare:
    with open(FLAGS.compare) as f:
      before = figures_only(json.load(f))
    before = {k: v for k, v in before.items() if k in results}
    lines = differences(before, results, FLAGS.tolerance_db)
    print("\n".join(lines) if lines else f"same numbers on all {len(results)} runs")
    if lines:
      sys.exit(1)
  if FLAGS.study and FLAGS.shard == "0/1":
    found = identity.verdicts(STUDIES[FLAGS.study], results)
    print(identity.write(FLAGS.study, STUDIES[FLAGS.study].budget_s, found, git=git))
    for v, scenes in found.items():
      print(f"{v}: " + ", ".join(f"{s} {'identical' if same else 'differs'}"
                                 for s, same in scenes.items()))
  if FLAGS.record:
    print(code_version.record(state["commit"], results, FLAGS.views,
                              digests=code_version.step_table_digests()))


if __name__ == "__main__":
  flags.mark_flag_as_required("out")
  app.run(main)
