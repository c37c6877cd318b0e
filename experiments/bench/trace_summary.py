"""Where a jitted step's device time goes: a jax.profiler trace, summarised.

  summary = trace_summary.profile(lambda: run_steps(n), n)

Traces `n` calls of a step and reads the trace back (jax.profiler.ProfileData)
into a small dict: the wall time per step, the time the device's streams were
busy (the union of kernel intervals, so overlapping kernels count once), the
rest as idle gaps (launch latency, host work, synchronisation), and the busy
time split by kind of kernel (matrix products, fused elementwise work,
reductions, copies) with the top kernels by time. On a CPU the XLA ops' events
stand in for kernels, so the function also runs in CI.
"""
import collections
import glob
import os
import re
import tempfile
import time
from typing import Callable

import jax
from jax.profiler import ProfileData

# Kernel kinds by name. cuBLAS / cuBLASLt / CUTLASS kernels and XLA's Triton
# GEMMs are matrix products; names of XLA's fusions say what they fuse.
_KINDS = (
    ("matmul", re.compile(r"gemm|cublas|cutlass|xmma|nvjet|wgmma|dot|matmul|sm90_|triton_gemm", re.I)),
    ("copy", re.compile(r"memcpy|memset|copy|transpose", re.I)),
    ("reduce", re.compile(r"reduce|reduction|scatter|sort|cumsum", re.I)),
    ("elementwise", re.compile(r"fusion|loop|input_|wrapped|convert|broadcast|select|multiply|add", re.I)),
)
TOP = 12


def kernel_kind(name: str) -> str:
  """'matmul', 'copy', 'reduce', 'elementwise' or 'other' for a kernel's name."""
  for kind, pattern in _KINDS:
    if pattern.search(name):
      return kind
  return "other"


def _union_ns(intervals):
  """Total length of the union of [start, end) intervals (ns)."""
  total, end = 0.0, float("-inf")
  for s, e in sorted(intervals):
    if s > end:
      total += e - s
      end = e
    elif e > end:
      total += e - end
      end = e
  return total


def _kernel_events(data: ProfileData):
  """(name, start_ns, duration_ns) of every kernel: the device planes' stream
  lines on a GPU, the events of XLA ops (those with an `hlo_op` stat) on a CPU."""
  events = []
  for plane in data.planes:
    on_device = plane.name.startswith("/device:")
    for line in plane.lines:
      if on_device:
        if not line.name.startswith("Stream"):  # 'XLA Modules' / 'XLA Ops' repeat the streams
          continue
      elif plane.name != "/host:CPU" or line.name == "python":
        continue
      for ev in line.events:
        if ev.duration_ns <= 0:
          continue
        if not on_device and "hlo_op" not in dict(ev.stats):  # thread-pool bookkeeping
          continue
        events.append((ev.name, ev.start_ns, ev.duration_ns))
  return events


def summarise(data: ProfileData, wall_s: float, n_steps: int) -> dict:
  """The trace of `n_steps` steps that took `wall_s` seconds -> per-step ms
  (wall, busy, idle) and the busy time by kernel kind and by kernel."""
  events = _kernel_events(data)
  busy_ns = _union_ns([(s, s + d) for _, s, d in events])
  by_kind = collections.Counter()
  by_name = collections.Counter()
  count = collections.Counter()
  for name, _, d in events:
    by_kind[kernel_kind(name)] += d
    by_name[name] += d
    count[name] += 1
  kernel_ns = sum(by_kind.values())
  per_step = lambda ns: ns / 1e6 / n_steps
  wall_ms = 1e3 * wall_s / n_steps
  return {
      "steps": n_steps,
      "wall_ms": wall_ms,
      "busy_ms": per_step(busy_ns),
      "idle_share": max(0.0, 1.0 - per_step(busy_ns) / wall_ms) if wall_ms else 0.0,
      "kernels_per_step": len(events) / n_steps,
      "kernel_ms_by_kind": {k: per_step(v) for k, v in sorted(by_kind.items())},
      "kernel_share_by_kind": {k: v / kernel_ns for k, v in sorted(by_kind.items())} if kernel_ns else {},
      "top_kernels": [{"name": name[:120], "kind": kernel_kind(name), "ms": per_step(ns),
                       "calls_per_step": count[name] / n_steps}
                      for name, ns in by_name.most_common(TOP)],
  }


def profile(run: Callable[[], None], n_steps: int) -> dict:
  """Traces one call of `run` (which makes `n_steps` steps and waits for
  them; call it once beforehand so that nothing compiles here) and returns
  `summarise`'s dict."""
  with tempfile.TemporaryDirectory() as d:
    jax.profiler.start_trace(d)
    t = time.perf_counter()
    run()
    wall = time.perf_counter() - t
    jax.profiler.stop_trace()
    paths = glob.glob(os.path.join(d, "**", "*.xplane.pb"), recursive=True)
    if not paths:
      raise RuntimeError(f"jax.profiler wrote no .xplane.pb under {d}")
    return summarise(ProfileData.from_file(paths[0]), wall, n_steps)


def format_summary(label: str, s: dict) -> str:
  """A few printed lines of one summary."""
  kinds = ", ".join(f"{k} {v:.2f} ms" for k, v in s["kernel_ms_by_kind"].items())
  lines = [f"{label}: {s['wall_ms']:.2f} ms a step, device busy {s['busy_ms']:.2f} ms "
           f"({100 * (1 - s['idle_share']):.0f}%), {s['kernels_per_step']:.0f} kernels; {kinds}"]
  for k in s["top_kernels"][:6]:
    lines.append(f"  {k['ms']:7.3f} ms  x{k['calls_per_step']:.0f}  {k['kind']:11} {k['name'][:70]}")
  return "\n".join(lines)
