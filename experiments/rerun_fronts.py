"""Reruns the CPU suite's front pairs on the current code, scene by scene.

  python experiments/rerun_fronts.py [--scenes=a,b] [--seeds=0,1] [--dry_run]
  python experiments/rerun_fronts.py --methods=nerf_paper,halo+unseen --seeds=0

For each scene, `nerf_tuned` on the first core and `halo` on the second train
side by side (one benchmark.py process each, --add_fronts), both seeds of the
scene in turn. Their records are written outside the repository (--work),
so no run sees a modified tree, and the scene's records are copied into
results/ and committed together once all of them have finished, so no
scene's front mixes two versions of the code. A method whose records of the
scene already carry the current code version (experiments/code_version.py)
is skipped there, so the command resumes where a killed one stopped; a file
--work/stop ends it after the scene in progress. Other methods pair the same
way (--methods, one per core); a scene runs those of them its suite plans.
"""
import json
import os
import re
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

SUITE_MODE = os.path.join("cpu", "time")   # benchmark.py's <suite>/<mode> under results and scratch
SUITE_DIR = os.path.join("results", SUITE_MODE)


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


def only_regex(scene, method, seeds) -> str:
  """benchmark.py's --only for these runs ('+' in a method's name is literal)."""
  return f"^{re.escape(scene)}/{re.escape(method)}/seed({'|'.join(seeds)})$"


def _launch(work, scene, method, core, seeds):
  """One benchmark.py process training `method`'s `seeds` of `scene` on `core`."""
  log = open(os.path.join(work, f"{scene}.{method}.log"), "w")  # pylint: disable=consider-using-with
  return subprocess.Popen(  # pylint: disable=consider-using-with
      [sys.executable, os.path.join(REPO, "experiments", "benchmark.py"), "--suite=cpu",
       "--add_fronts", f"--results={os.path.join(work, 'results')}",
       f"--scratch={os.path.join(work, 'scratch')}", f"--first_core={core}",
       f"--only={only_regex(scene, method, seeds)}"],
      cwd=REPO, stdout=log, stderr=subprocess.STDOUT)


def run_scene(scene, methods, version, *, work, seeds, cores, repo=REPO, launch=_launch):
  """Trains the scene's `methods` (method m on core cores[m]) into a fresh
  copy of repo's results/ under `work`, then copies their records into repo
  and commits them. The scene's workdirs are cleared first: a run killed with
  its scene is trained again, not resumed on another version of the code."""
  shutil.rmtree(os.path.join(work, "results"), ignore_errors=True)
  shutil.copytree(os.path.join(repo, "results"), os.path.join(work, "results"))
  runs = [(m, seed) for m in methods for seed in seeds]
  for m, seed in runs:  # the records to replace: run again, not skipped as done
    path = os.path.join(work, SUITE_DIR, scene, m, f"seed{seed}.json")
    if os.path.exists(path):
      os.remove(path)
    shutil.rmtree(os.path.join(work, "scratch", SUITE_MODE, scene, m, f"seed{seed}"),
                  ignore_errors=True)
  procs = [launch(work, scene, m, cores[m], seeds) for m in methods]
  codes = [p.wait() for p in procs]
  if any(codes) or not up_to_date(work, scene, methods, seeds, version):
    sys.exit(f"{scene}: a run failed or has no front (exit codes {codes}; logs in {work})")
  for m, seed in runs:
    rel = os.path.join(SUITE_DIR, scene, m, f"seed{seed}.json")
    os.makedirs(os.path.dirname(os.path.join(repo, rel)), exist_ok=True)
    shutil.copy(os.path.join(work, rel), os.path.join(repo, rel))
  subprocess.run(["git", "-C", repo, "add", os.path.join(SUITE_DIR, scene)], check=True)
  subprocess.run(["git", "-C", repo, "commit", "-q", "-m",
                  f"cpu/time: {' and '.join(methods)} fronts on {scene}, seeds "
                  f"{', '.join(seeds)}, code {version}", "--", os.path.join(SUITE_DIR, scene)],
                 check=True)
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
    planned = [m for m in FLAGS.methods if m in by_name[scene].methods]  # the suite's plan
    methods = [m for m in planned if not up_to_date(REPO, scene, [m], FLAGS.seeds, version)]
    if not methods:
      print(f"up to date  {scene} (code {version})", flush=True)
      continue
    print(f"{'would run' if FLAGS.dry_run else 'running'}   {scene}: {', '.join(methods)} "
          f"(code {version})", flush=True)
    if not FLAGS.dry_run:
      run_scene(scene, methods, version, work=FLAGS.work, seeds=FLAGS.seeds,
                cores={m: FLAGS.methods.index(m) for m in methods})


if __name__ == "__main__":
  define_flags()
  app.run(main)
