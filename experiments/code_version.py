"""Which version of the code made a result file.

A record keeps the commit its run started from, but result files are
committed while a suite runs, so runs of one code can name different
commits. The version is the newest commit at or before the record's that
touched the code that trains, scores and times (TRAINING_CODE).
"""
import functools
import os
import subprocess

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
TRAINING_CODE = ("halo_jax", "configs", "experiments/benchmark.py", "experiments/suites.py")
# Commits that touched TRAINING_CODE without moving any number a suite
# records (full sha: why), so that records on either side of one stay one
# version and are not rerun for it.
NEUTRAL = {
    "21b4f879a94ceaf17eac81c58dffc877fc9d8281":
        "trig: NaN for angles past 2^30; the suites' angles stay below 2^13",
    "af12b4feb3d78403dd8b729a0499255e1db51be3":
        "encoding: the 12-bit split through trig.top12, bit for bit the same",
    "69539d48adebc0b9513c1a3fbeb24d97bb338156":
        "trig: the polynomial path jitted; inside jit it compiles to the same HLO",
    "1214dfce1c98db7d25e5cb1f5b1ba0c4e612512c":
        "benchmark: --only checked before any run; no run's settings change",
    "3e71848fe09ad84634e10c07dfd1f0c71e962259":
        "benchmark: plan searches with its compiled pattern; the same runs",
    "e272729bcab79ce153632a6284ac315adb022ca8":
        "benchmark: plan filters through experiments/selection.py; the same runs",
    "52a29aecf8d81419544df8ec2a91b77f4780367b":
        "benchmark: selection.select's message parts as two arguments; the same runs",
}


@functools.lru_cache(maxsize=None)
def of_commit(commit: str, repo: str = REPO) -> str:
  """sha7 of the newest commit at or before `commit` that touched
  TRAINING_CODE and is not NEUTRAL; `commit`'s own sha7 where git cannot say
  ('' stays '')."""
  if not commit:
    return ""
  try:
    out = subprocess.run(["git", "-C", repo, "log", "--format=%H", commit, "--", *TRAINING_CODE],
                         capture_output=True, text=True, timeout=20, check=True).stdout.split()
  except (OSError, subprocess.SubprocessError):
    out = []
  version = next((c for c in out if c not in NEUTRAL), "")
  return version[:7] or commit[:7]


def of_records(records) -> str:
  """The code versions of `records` (dicts with a 'provenance'), oldest
  first as met, joined by ', '; '+' marks a version run from a modified tree."""
  seen = []
  for r in records:
    git = r.get("provenance", {}).get("git", {})
    v = of_commit(git.get("commit") or "") or "?"
    v += "+" if git.get("dirty") else ""
    if v not in seen:
      seen.append(v)
  return ", ".join(seen)
