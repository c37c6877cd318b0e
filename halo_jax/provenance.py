"""Where a result came from: software versions, device, machine speed, code version.

Results in this project depend on time budgets, so a figure without the
machine's measured speed and the code's commit cannot be compared with
another. `collect()` gathers what every info.json and results.json records.
"""
import functools
import hashlib
import os
import platform
import subprocess
import sys
import time

import jax
import jax.numpy as jnp

_REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def _version(module: str):
  try:
    return __import__(module).__version__
  except (ImportError, AttributeError):
    return None


def cpu_model() -> str:
  """The CPU's marketing name (/proc/cpuinfo on Linux, platform otherwise)."""
  try:
    with open("/proc/cpuinfo") as f:
      for line in f:
        if line.startswith("model name"):
          return line.split(":", 1)[1].strip()
  except OSError:
    pass
  return platform.processor() or platform.machine()


def cpu_count() -> int:
  """Cores this process may run on (its affinity mask, not the machine's total)."""
  try:
    return len(os.sched_getaffinity(0))
  except AttributeError:
    return os.cpu_count() or 1


# The files whose contents decide what a run trains, scores and times: two
# checkouts that agree on them make the same numbers, whatever else differs.
# The benchmark's runner and suites lived in experiments/ before halo_jax/bench/;
# their old paths stay so that older commits hash as they always did.
TRAINING_CODE = ("halo_jax", "configs", "experiments/benchmark.py", "experiments/suites.py")


def _git(repo, *args) -> str:
  return subprocess.run(["git", "-C", repo, *args], capture_output=True, text=True,
                        timeout=20, check=True).stdout.strip()


@functools.lru_cache(maxsize=None)
def code_tree(commit: str, repo: str = _REPO):
  """12 hex digits naming the contents of TRAINING_CODE at `commit` (a hash
  of their git blob ids), or None where git cannot say. Commits that touched
  none of those files share it."""
  try:
    listing = _git(repo, "ls-tree", "-r", commit, "--", *TRAINING_CODE)
  except (OSError, subprocess.SubprocessError):
    return None
  return hashlib.sha1(listing.encode()).hexdigest()[:12] if listing else None


def git_state(repo: str = _REPO) -> dict:
  """{'commit', 'dirty', 'code_tree', 'code_dirty'} of the checkout holding the code.

  dirty: any tracked file modified; code_dirty: a file of TRAINING_CODE
  modified or added, so that `code_tree` (the commit's) does not describe the
  code that ran. None where the code is not in a git checkout (an installed wheel).
  """
  try:
    commit = _git(repo, "rev-parse", "HEAD")
    dirty = bool(_git(repo, "status", "--porcelain", "--untracked-files=no"))
    code_dirty = bool(_git(repo, "status", "--porcelain", "--", *TRAINING_CODE))
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


def collect(measure_peak: bool = True) -> dict:
  """The provenance record: versions, device, CPU, git state, matmul peak, command."""
  devices = jax.devices()
  return {
      "versions": {"python": platform.python_version(), "jax": jax.__version__,
                   "jaxlib": _version("jaxlib"), "flax": _version("flax"),
                   "optax": _version("optax"), "numpy": _version("numpy")},
      "device": {"backend": jax.default_backend(), "kind": devices[0].device_kind,
                 "count": len(devices), "processes": jax.process_count()},
      "cpu": {"model": cpu_model(), "cores_used": cpu_count(), "cores_total": os.cpu_count()},
      "git": git_state(),
      "matmul_peak_gflops": round(matmul_peak_gflops(), 1) if measure_peak else None,
      "command": " ".join([os.path.basename(sys.executable)] + sys.argv),
      "host": platform.node(),
      "time_utc": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
  }
