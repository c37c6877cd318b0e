"""Runs CI as it runs on a fresh machine and keeps what it printed: clones
the repository's HEAD into a temporary folder, times `.ci/run` there and
writes results/ci/<commit>.txt (experiments/bench/ci_records.py reads it; the
README's CI sentence comes from the newest record: `python -m
experiments.report`).

  python -m experiments.ci_record --conditions="without the datasets"
  python -m experiments.ci_record --conditions="..." --dry_run   # the header only

Say in --conditions what else the machine did (a loaded machine takes longer):
the record keeps it beside the figures.
"""
import datetime
import os
import shutil
import subprocess
import sys
import tempfile
import time

from absl import flags

from experiments.bench import ci_records, code_version, tool

FLAGS = flags.FLAGS


def _header(commit: str) -> str:
  cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
  cpu = code_version.machine().split(" (")[0]
  family = code_version.machine().partition("family ")[2].split(",")[0]
  date = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d")
  return (f"CI (.ci/run) on a fresh clone of {commit}, {cores} CPU cores ({cpu} family "
          f"{family}), {date}, {FLAGS.conditions}:")


# pytest's lines of why a test failed ("E   assert ..."), kept up to this many
MAX_WHY_LINES = 40


def kept_lines(out) -> list:
  """What a record keeps of pytest's output `out` (lines) besides its last:
  which tests failed (the short summary's FAILED / ERROR lines) and why (the
  first MAX_WHY_LINES of its `E ` lines, each cut at 200 characters)."""
  failed = [l for l in out if l.startswith(("FAILED ", "ERROR "))]
  why = [l[:200] for l in out if l.startswith("E ")][:MAX_WHY_LINES]
  return failed + why


def define_flags():
  """The tool's flags, defined on launch (tests import this module beside others)."""
  flags.DEFINE_string("conditions", "", "What else the machine had: data, other jobs (required).")
  flags.DEFINE_bool("dry_run", False, "Print the record's header; run nothing.")


def main(argv):
  del argv
  if not FLAGS.conditions:
    sys.exit("--conditions: say what else the machine had (e.g. 'without the datasets')")
  commit = subprocess.run(["git", "-C", ci_records.REPO, "rev-parse", "--short=7", "HEAD"],
                          capture_output=True, text=True, check=True).stdout.strip()
  header = _header(commit)
  if FLAGS.dry_run:
    print(header)
    return
  clone = tempfile.mkdtemp(prefix="halo_ci_")
  try:
    subprocess.run(["git", "clone", "-q", ci_records.REPO, clone], check=True)
    start = time.perf_counter()
    done = subprocess.run([os.path.join(clone, ".ci", "run")], cwd=clone,
                          capture_output=True, text=True,
                          env=dict(os.environ, COLUMNS="200"))  # summaries not cut short
    seconds = time.perf_counter() - start
  finally:
    shutil.rmtree(clone, ignore_errors=True)
  out = [l for l in done.stdout.strip().splitlines() if l.strip()]
  text = "\n".join([header] + kept_lines(out) + out[-1:]
                    + [f"real\t{int(seconds // 60)}m{seconds % 60:.3f}s"]) + "\n"
  path = os.path.join(ci_records.FOLDER, f"{commit}.txt")
  ci_records.parse(text, path)  # a run whose summary is missing fails here, not in the README
  with open(path, "w") as f:
    f.write(text)
  print(text, end="")
  if done.returncode:
    sys.exit(f".ci/run exited {done.returncode}: {path} keeps its summary")


if __name__ == "__main__":
  define_flags()
  tool.run(sys.modules[__name__], main)
