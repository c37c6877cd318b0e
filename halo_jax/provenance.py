"""Where a run came from: software versions, device, CPU, and a digest of the
code that ran.

Collected once per run (the pipeline's start) and cheaply: the library runs
no git and times nothing here. The benchmark (experiments/bench/git_state.py)
adds the commit and the machine's matmul peak to the records it writes.
"""
import functools
import hashlib
import os
import platform
import sys
import time

import jax

from halo_jax import config_files

_PACKAGE = os.path.dirname(os.path.abspath(__file__))
# the files that decide what a run trains: the package's code and tables,
# and the scene configs (the clone's configs/, or the installed copy)
_CODE_SUFFIXES = (".py", ".json")


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


def _code_files(folder: str):
  for root, dirs, files in os.walk(folder):
    dirs[:] = sorted(d for d in dirs if not d.startswith((".", "__pycache__")))
    for name in sorted(files):
      if name.endswith(_CODE_SUFFIXES):
        yield os.path.join(root, name)


@functools.lru_cache(maxsize=None)
def code_digest() -> str:
  """12 hex digits naming the contents of the package's code and the scene
  configs as they are on disk (edits included): two runs with the same digest
  ran the same code, whatever the checkout or install."""
  h = hashlib.sha1()
  configs = config_files.shipped_folder()
  folders = [_PACKAGE] + ([configs] if configs and not configs.startswith(_PACKAGE) else [])
  for folder in folders:
    for path in _code_files(folder):
      with open(path, "rb") as f:
        h.update(os.path.relpath(path, os.path.dirname(folder)).encode() + b"\0"
                 + hashlib.sha1(f.read()).digest())
  return h.hexdigest()[:12]


def collect() -> dict:
  """The provenance record: versions, device, CPU, the code's digest, command."""
  devices = jax.devices()
  return {
      "versions": {"python": platform.python_version(), "jax": jax.__version__,
                   "jaxlib": _version("jaxlib"), "flax": _version("flax"),
                   "optax": _version("optax"), "numpy": _version("numpy")},
      "device": {"backend": jax.default_backend(), "kind": devices[0].device_kind,
                 "count": len(devices), "processes": jax.process_count()},
      "cpu": {"model": cpu_model(), "cores_used": cpu_count(), "cores_total": os.cpu_count()},
      "code": {"digest": code_digest()},
      "command": " ".join([os.path.basename(sys.executable)] + sys.argv),
      "host": platform.node(),
      "time_utc": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
  }
