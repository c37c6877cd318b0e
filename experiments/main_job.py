"""The README's main job, run as a newcomer runs it and kept: its table, its
plot and its time.

  python -m experiments.main_job --conditions="2 idle cores"   # runs it (minutes)
  python -m experiments.main_job --report_only                # README block from the record
  python -m experiments.main_job --from_workdir=DIR --wall_s=S --conditions=...
                     # keep a run of the README's command made by hand in DIR, timed by `time`

Runs the README's command (COMMAND, in a fresh temporary workdir), times it,
and writes results/main_job/default.json (every method's record, the
command, the wall time, the machine, the commit and --conditions),
docs/images/main_job.png (held-out PSNR against reference seconds) and the
README's block between `<!-- main_job:begin -->` and `<!-- main_job:end -->`
(the table and lines halo-compare printed; tests/test_generated_pages.py holds
the README to the record).
"""
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time

from absl import flags
from experiments.bench import code_version, git_state, report, tool
from experiments.bench.paths import REPO
from halo_jax.cli import compare

ARGS = ["--config=configs/default.py", "--methods=halo,nerf_tuned"]
COMMAND = "halo-compare " + " ".join(ARGS[:1]) + " --workdir=/tmp/halo_default " + ARGS[1]
RECORD = os.path.join(REPO, "results", "main_job", "default.json")
IMAGE = os.path.join(REPO, "docs", "images", "main_job.png")

FLAGS = flags.FLAGS


def block(record) -> str:
  """The README's main-job block: what halo-compare printed, its time, the plot."""
  table = compare.write_report(record["methods"], tempfile.mkdtemp(), record["num_test_views"])
  rows = [l for l in table.splitlines() if l.startswith("|") or l.startswith("- ")]
  m = record["run"]
  minutes = f"{int(m['wall_s'] // 60)} min {int(round(m['wall_s'] % 60))} s"
  return "\n".join(
      [f"`{record['command']}` took {minutes} on a fresh workdir ({m['cores']} cores of {m['machine']}, "
       f"{m['conditions']}; commit {m['commit'][:7]}, {m['date']}) and printed "
       f"([results/main_job/default.json](results/main_job/default.json)):", ""]
      + [r for r in rows if r.startswith("|")] + [""]
      + [r for r in rows if r.startswith("- ")]
      + ["", "![held-out PSNR against training time](docs/images/main_job.png)"])


def define_flags():
  """The tool's flags, defined on launch (tests import this module beside others)."""
  flags.DEFINE_string("conditions", "", "What else the machine ran (required to run).")
  flags.DEFINE_bool("report_only", False, "Run nothing: the README block from the record.")
  flags.DEFINE_string("from_workdir", "", "Keep the README command's run in this workdir instead "
                      "of running it (with --wall_s, its time).")
  flags.DEFINE_float("wall_s", 0.0, "With --from_workdir: the run's wall seconds.")


def main(argv):
  del argv
  if not FLAGS.report_only:
    if not FLAGS.conditions:
      sys.exit("--conditions: say what else the machine ran (e.g. '2 idle cores')")
    workdir, wall = FLAGS.from_workdir, FLAGS.wall_s
    if not workdir:
      workdir = tempfile.mkdtemp(prefix="halo_main_job_")
      exe = os.path.join(os.path.dirname(sys.executable), "halo-compare")
      start = time.perf_counter()
      done = subprocess.run([exe, *ARGS, f"--workdir={workdir}"], cwd=REPO)
      wall = time.perf_counter() - start
      if done.returncode:
        sys.exit(f"the main job exited {done.returncode}; nothing recorded")
    elif wall <= 0:
      sys.exit("--from_workdir needs --wall_s, the run's wall seconds")
    with open(os.path.join(workdir, "results.json")) as f:
      methods = json.load(f)
    n_test = methods[next(iter(methods))]["num_views"]
    git = git_state.git_state()
    record = {"command": COMMAND, "num_test_views": n_test,
              "run": {"wall_s": round(wall, 1), "machine": code_version.machine(),
                      "cores": len(os.sched_getaffinity(0)), "conditions": FLAGS.conditions,
                      "commit": git["commit"], "code_dirty": git["code_dirty"],
                      "date": time.strftime("%Y-%m-%d", time.gmtime())},
              "methods": methods}
    with open(RECORD, "w") as f:
      json.dump(record, f, indent=1)
      f.write("\n")
    compare.plot_curves(methods, IMAGE, size=(6, 3.6), dpi=110)
    if not FLAGS.from_workdir:
      shutil.rmtree(workdir, ignore_errors=True)
  with open(RECORD) as f:
    record = json.load(f)
  if report.update_readme(os.path.join(REPO, "README.md"), block(record), "main_job"):
    print("updated README.md's main-job block from", os.path.relpath(RECORD, REPO))


if __name__ == "__main__":
  define_flags()
  tool.run(sys.modules[__name__], main)
