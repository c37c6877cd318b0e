"""What the benchmark adds to a run's provenance: the commit and code tree of
the clone (git), and this machine's matmul peak. The library records neither
(halo_jax/provenance.py); the benchmark's records carry both, once per run."""
import functools
import hashlib
import subprocess
import time

import jax
import jax.numpy as jnp

from halo_jax import provenance
from experiments.bench.paths import REPO

# The files whose contents decide what a run trains, scores and times: two
# checkouts that agree on them make the same numbers, whatever else differs.
# The runner, the suites and the fingerprint runs lived in experiments/ and
# then under halo_jax/; the old paths stay so that older commits hash as they
# always did.
TRAINING_CODE = ("halo_jax", "configs", "experiments/benchmark.py", "experiments/suites.py",
                 "experiments/bench/benchmark.py", "experiments/bench/suites.py",
                 "experiments/bench/fingerprint.py")
# Data beside the code, not code: the committed step table turns a budget into
# step counts, which a record keeps (its protocol summary) and the fingerprint
# entry's digests follow (code_version.step_table_digests); the fingerprint run
# measures its own table. Left out, a commit that measures new keys keeps its
# code's tree, so HEAD stays measured. Trees before TABLE_OUT hashed it in.
DATA_FILES = ("halo_jax/step_table.json",)

def _git(repo, *args) -> str:
  return subprocess.run(["git", "-C", repo, *args], capture_output=True, text=True,
                        timeout=20, check=True).stdout.strip()


@functools.lru_cache(maxsize=None)
def code_tree(commit: str, repo: str = REPO, with_data: bool = False):
  """12 hex digits naming the contents of TRAINING_CODE but DATA_FILES at
  `commit` (a hash of their git blob ids), or None where git cannot say.
  Commits that touched none of those files share it. with_data: the earlier
  definition, DATA_FILES hashed in (the key of records that stored no tree)."""
  if len(commit) == 40:  # a full hash names one tree for good
    return _code_tree(commit, repo, with_data)
  return _code_tree.__wrapped__(commit, repo, with_data)


@functools.lru_cache(maxsize=None)
def _code_tree(commit, repo, with_data):
  try:
    listing = _git(repo, "ls-tree", "-r", commit, "--", *TRAINING_CODE)
  except (OSError, subprocess.SubprocessError):
    return None
  if not with_data:
    listing = "\n".join(l for l in listing.splitlines()
                        if l.split("\t", 1)[-1] not in DATA_FILES)
  return hashlib.sha1(listing.encode()).hexdigest()[:12] if listing else None


def git_state(repo: str = REPO) -> dict:
  """{'commit', 'dirty', 'code_tree', 'code_dirty'} of the checkout holding the code.

  dirty: any tracked file modified; code_dirty: a file of TRAINING_CODE (but
  DATA_FILES) modified or added, so that `code_tree` (the commit's) does not describe the
  code that ran. None where the code is not in a git checkout (an installed wheel).
  """
  try:
    commit = _git(repo, "rev-parse", "HEAD")
    dirty = bool(_git(repo, "status", "--porcelain", "--untracked-files=no"))
    code_dirty = bool(_git(repo, "status", "--porcelain", "--", *TRAINING_CODE,
                           *(f":(exclude){f}" for f in DATA_FILES)))
  except (OSError, subprocess.SubprocessError):
    return {"commit": None, "dirty": None, "code_tree": None, "code_dirty": None}
  return {"commit": commit, "dirty": dirty, "code_tree": code_tree(commit, repo),
          "code_dirty": code_dirty}


@functools.lru_cache(maxsize=None)
def matmul_peak_gflops(n: int = 0, rounds: int = 5) -> float:
  """GFLOP/s of a jitted n x n x n fp32 matmul at JAX's default precision, the
  best of `rounds` (the least disturbed by other work); n defaults to 2048 on
  CPU and 8192 on an accelerator. Measured once per process."""
  if n <= 0:
    n = 2048 if jax.default_backend() == "cpu" else 8192
  ka, kb = jax.random.split(jax.random.PRNGKey(0))
  a = jax.random.normal(ka, (n, n), jnp.float32)  # random: zeros can run faster
  b = jax.random.normal(kb, (n, n), jnp.float32)
  mm = jax.jit(lambda a, b: a @ b)
  jax.block_until_ready(mm(a, b))
  best = float("inf")
  for _ in range(rounds):
    t = time.perf_counter()
    jax.block_until_ready(mm(a, b))
    best = min(best, time.perf_counter() - t)
  return 2.0 * n ** 3 / best / 1e9


def _clone(measure_peak: bool = True) -> dict:
  return {"git": git_state(),
          "matmul_peak_gflops": round(matmul_peak_gflops(), 1) if measure_peak else None}


def collect(measure_peak: bool = True) -> dict:
  """The library's provenance record with the clone's git state and, unless
  measure_peak is False, this machine's matmul peak."""
  return dict(provenance.collect(), **_clone(measure_peak))


_STARTED = {}  # the clone's git state when a long-running tool started (pin_start)


def pin_start() -> None:
  """Takes the clone's git state now, at a tool's start, for every record it
  stamps: the code its runs execute is what it imported then, and commits made
  while it trains must not be named as theirs."""
  _STARTED["git"] = git_state()


def stamp(record: dict) -> dict:
  """`record` (a run's result) with the clone's git state (pinned at the
  tool's start where it was: pin_start) and the matmul peak in its provenance."""
  clone = _clone()
  clone["git"] = _STARTED.get("git", clone["git"])
  record["provenance"] = dict(record.get("provenance") or {}, **clone)
  return record
