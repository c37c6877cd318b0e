"""Progress bars for every command that runs longer than a few seconds: one
helper, so that every bar looks alike and writes to stderr (piped stdout
stays clean).

  steps(iterable, what, desc)  a bar over a loop of whole things (runs, grid
                               points, snapshots): count, total and an ETA
  Render(num_views, what, rays_per_view, desc)
                               a bar over the views or frames of a render,
                               advanced chunk by chunk (a view is many
                               chunks), ending with the rays/s it rendered
"""
import sys
import time

import tqdm

# A bar refreshes at most this often (seconds): cheap, and a log file that
# captures stderr grows by a line per interval, not per step.
MIN_INTERVAL_S = 1.0


def bar(total, desc: str, unit: str, **kwargs) -> tqdm.tqdm:
  """A tqdm bar on stderr with the project's settings."""
  return tqdm.tqdm(total=total, desc=desc, unit=unit, file=sys.stderr, dynamic_ncols=True,
                   mininterval=MIN_INTERVAL_S, **kwargs)


def steps(iterable, what: str, desc: str = "", total=None):
  """Yields from `iterable` under a bar counting `what` (runs, points)."""
  items = list(iterable) if total is None and not hasattr(iterable, "__len__") else iterable
  with bar(total if total is not None else len(items), desc or what, what) as b:
    for item in items:
      yield item
      b.update(1)


class Render:
  """A bar over `num_views` views (or frames) of `rays_per_view` rays each,
  advanced by rays and counting whole views; it shows the rays/s rendered.
  leave=False: the bar is gone once closed (a render inside a training bar)."""

  def __init__(self, num_views: int, what: str, rays_per_view: int, desc: str,
               leave: bool = True):
    self.rays_per_view = max(int(rays_per_view), 1)
    self.rays, self.start = 0, time.perf_counter()
    self.bar = bar(int(num_views), desc, what, leave=leave)

  def advance(self, rays: int):
    self.rays += rays
    seconds = time.perf_counter() - self.start
    if seconds > 0:
      self.bar.set_postfix_str(f"{self.rays / seconds:.3g} rays/s", refresh=False)
    whole = min(self.rays // self.rays_per_view, self.bar.total)
    if whole > self.bar.n:
      self.bar.update(whole - self.bar.n)

  def close(self, finished: bool = True):
    if finished and self.bar.n < self.bar.total:
      self.bar.update(self.bar.total - self.bar.n)
    self.bar.close()

  def __enter__(self):
    return self

  def __exit__(self, kind, *_):
    self.close(finished=kind is None)
