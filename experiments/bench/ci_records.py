"""The CI records in results/ci/: what `.ci/run` printed on a fresh clone,
and the README's CI sentence made from the newest of them.

A record is a text file `results/ci/<commit>.txt` (experiments/ci_record.py
writes one):
  CI (.ci/run) on a fresh clone of <commit>, <cores> (<cpu>), <date>, <conditions>:
  <pytest's last line: N passed, M skipped, ... in S s (h:mm:ss)>
  real	<m>m<s>s
"""
import dataclasses
import glob
import os
import re
import subprocess

from experiments.bench.paths import REPO

FOLDER = os.path.join(REPO, "results", "ci")
_HEAD = re.compile(r"^CI \(\.ci/run\) on a fresh clone of (?P<commit>[0-9a-f]+), "
                   r"(?P<machine>.+?), (?P<date>\d{4}-\d\d-\d\d), (?P<conditions>.+):$")
_COUNT = re.compile(r"(\d+) (passed|skipped|failed|errors?)")
_TESTS_S = re.compile(r" in ([0-9.]+)s")
_REAL = re.compile(r"^real\s+(\d+)m([0-9.]+)s$", re.M)


@dataclasses.dataclass(frozen=True)
class Record:
  """One CI run: its commit, machine, date and conditions as the header says
  them; test counts; the tests' seconds and the whole run's (install too)."""
  commit: str
  machine: str
  date: str
  conditions: str
  counts: dict
  tests_s: float
  total_s: float
  path: str


def parse(text: str, path: str = "") -> Record:
  """A record's text -> Record; ValueError naming the file for one that is not."""
  lines = text.strip().splitlines()
  head = _HEAD.match(lines[0]) if lines else None
  real = _REAL.search(text)
  summary = next((l for l in lines[1:] if _TESTS_S.search(l) and _COUNT.search(l)), None)
  if not (head and real and summary):
    raise ValueError(f"{path or 'CI record'}: not a CI record (its header, pytest's summary "
                     "line or the `real` time is missing)")
  counts = {k if k != "error" else "errors": int(n) for n, k in _COUNT.findall(summary)}
  return Record(commit=head["commit"], machine=head["machine"], date=head["date"],
                conditions=head["conditions"], counts=counts,
                tests_s=float(_TESTS_S.search(summary).group(1)),
                total_s=60 * int(real.group(1)) + float(real.group(2)), path=path)


def _commit_time(commit: str) -> int:
  try:
    out = subprocess.run(["git", "-C", REPO, "show", "-s", "--format=%ct", commit],
                         capture_output=True, text=True, timeout=20, check=True).stdout
    return int(out.strip())
  except (OSError, subprocess.SubprocessError, ValueError):
    return 0


def newest(folder: str = FOLDER):
  """The record of the newest commit (by its date, then its commit time), or None."""
  records = []
  for path in glob.glob(os.path.join(folder, "*.txt")):
    with open(path) as f:
      records.append(parse(f.read(), path))
  if not records:
    return None
  return max(records, key=lambda r: (r.date, _commit_time(r.commit), r.commit))


def minutes(seconds: float) -> str:
  """'23 min 59 s': whole seconds first, so 1439.6 s is 24 min 0 s."""
  whole = int(round(seconds))
  return f"{whole // 60} min {whole % 60} s"


def readme_sentence(rec: Record) -> str:
  """The README's CI sentence, every figure from `rec`."""
  rel = os.path.relpath(rec.path, REPO) if rec.path else "results/ci"
  c = rec.counts
  tally = ", ".join(f"{c[k]} {k}" for k in ("passed", "skipped", "failed", "errors")
                    if c.get(k))
  return (f"CI (`.ci/run` on a fresh machine: the install, Chromium for the viewer's browser "
          f"test, then the second command, its tests on two pytest-xdist workers) took "
          f"{minutes(rec.total_s)} on a fresh clone of {rec.commit}, {rec.machine}, "
          f"{rec.date}, {rec.conditions}: {minutes(rec.tests_s)} in the tests, {tally} "
          f"([{rel}]({rel})).")
