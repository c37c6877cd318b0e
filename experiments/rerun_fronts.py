"""Reruns the CPU suite's front pairs on the current code, scene by scene.

  python experiments/rerun_fronts.py [--scenes=a,b] [--seeds=0,1] [--dry_run]
  python experiments/rerun_fronts.py --methods=nerf_paper,halo+unseen --seeds=0

For each scene, `nerf_tuned` on the first core and `halo` on the second train
side by side (one benchmark.py process each, --add_fronts), both seeds of the
scene in turn. Their records are written outside the repository (--work),
so no run sees a modified tree, and the scene's records are copied into
results/ and committed together once all of them have finished, so no
scene's front mixes two versions of the code. A scene whose records of both
methods already carry the current code version (experiments/code_version.py)
is skipped, so the command resumes where a killed one stopped; a file
--work/stop ends it after the scene in progress. Other methods pair the same
way (--methods, one per core); a scene runs those of them its suite plans.
"""
import glob
import json
import os
import shutil
import subprocess
import sys

from absl import app, flags

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
if __package__ in (None, ""):
  sys.path.insert(0, REPO)
from experiments import code_version, suites  # pylint: disable=g-import-not-at-top
from halo_jax import defaults  # pylint: disable=g-import-not-at-top

FLAGS = flags.FLAGS


def define_flags():
  """Defined on launch, not on import (tests import this beside benchmark.py)."""
  flags.DEFINE_list("scenes", [s.name for s in suites.CPU.scenes], "scenes, in order")
  flags.DEFINE_list("seeds", ["0", "1"], "seeds of each method")
  flags.DEFINE_list("methods", ["nerf_tuned", "halo"],
                    "one method per core, first core first (a scene runs those its suite plans)")
  flags.DEFINE_string("work", "/tmp/rerun_fronts", "results copy, workdirs and logs")
  flags.DEFINE_bool("dry_run", False, "say which scenes would run")

SUITE_DIR = os.path.join("results", "cpu", "time")


def _records(root, scene, method, seeds):
  out = []
  for seed in seeds:
    path = os.path.join(root, SUITE_DIR, scene, method, f"seed{seed}.json")
    if os.path.exists(path):
      with open(path) as f:
        out.append(json.load(f))
  return out


def current_version() -> str:
  head = subprocess.run(["git", "-C", REPO, "rev-parse", "HEAD"], capture_output=True, text=True,
                        check=True).stdout.strip()
  return code_version.of_commit(head)


def up_to_date(root, scene, methods, seeds, version) -> bool:
  """Every (method, seed) of the scene has a record with a front, made by `version`."""
  for m in methods:
    recs = _records(root, scene, m, seeds)
    if len(recs) < len(seeds) or not all(r.get("front") for r in recs):
      return False
    if code_version.of_records(recs) != version:
      return False
  return True


def run_scene(scene, methods, version):
  """Trains the scene's `methods` (each on its --methods core) into a fresh
  copy of results/ and commits their records."""
  work = os.path.join(FLAGS.work, "results")
  shutil.rmtree(work, ignore_errors=True)
  shutil.copytree(os.path.join(REPO, "results"), work)
  for m in methods:  # the records to replace: run again, not skipped as done
    for seed in FLAGS.seeds:
      path = os.path.join(work, SUITE_DIR, scene, m, f"seed{seed}.json")
      if os.path.exists(path):
        os.remove(path)
  seeds = "|".join(FLAGS.seeds)
  procs = []
  for m in methods:
    core = FLAGS.methods.index(m)
    log_path = os.path.join(FLAGS.work, f"{scene}.{m}.log")
    log = open(log_path, "w")  # pylint: disable=consider-using-with
    procs.append(subprocess.Popen(  # pylint: disable=consider-using-with
        [sys.executable, os.path.join(REPO, "experiments", "benchmark.py"), "--suite=cpu",
         "--add_fronts", f"--results={work}", f"--scratch={os.path.join(FLAGS.work, 'scratch')}",
         f"--first_core={core}", f"--only=^{scene}/{m}/seed({seeds})$"],
        cwd=REPO, stdout=log, stderr=subprocess.STDOUT))
  codes = [p.wait() for p in procs]
  if any(codes) or not up_to_date(work, scene, methods, FLAGS.seeds, version):
    sys.exit(f"{scene}: a run failed or has no front (exit codes {codes}; logs in {FLAGS.work})")
  for path in glob.glob(os.path.join(work, SUITE_DIR, scene, "*", "seed*.json")):
    method = path.split(os.sep)[-2]
    if method in methods and os.path.basename(path)[4:-5] in FLAGS.seeds:
      shutil.copy(path, os.path.join(REPO, os.path.relpath(path, FLAGS.work)))
  subprocess.run(["git", "-C", REPO, "add", os.path.join(SUITE_DIR, scene)], check=True)
  subprocess.run(["git", "-C", REPO, "commit", "-q", "-m",
                  f"cpu/time: {' and '.join(methods)} fronts on {scene}, seeds "
                  f"{', '.join(FLAGS.seeds)}, code {version}"], check=True)
  print(f"committed {scene}", flush=True)


def main(argv):
  del argv
  os.makedirs(FLAGS.work, exist_ok=True)
  version = current_version()
  by_name = {s.name: s for s in suites.CPU.scenes}
  for scene in FLAGS.scenes:
    if os.path.exists(os.path.join(FLAGS.work, "stop")):
      print("stop file: stopping", flush=True)
      break
    needs = by_name[scene].needs
    if needs and not os.path.isdir(os.path.join(defaults.data_root(), needs)):
      print(f"no data     {scene} ({needs} not under {defaults.data_root()})", flush=True)
      continue
    methods = [m for m in FLAGS.methods if m in by_name[scene].methods]  # the suite's plan
    if not methods:
      continue
    if up_to_date(REPO, scene, methods, FLAGS.seeds, version):
      print(f"up to date  {scene} (code {version})", flush=True)
      continue
    print(f"{'would run' if FLAGS.dry_run else 'running'}   {scene} (code {version})", flush=True)
    if not FLAGS.dry_run:
      run_scene(scene, methods, version)


if __name__ == "__main__":
  define_flags()
  app.run(main)
