"""Stopping a run on SIGTERM or SIGINT (a scheduler's pre-emption, Ctrl-C)
with its training state saved.

An entry point installs the handlers for the whole run (`handled`). Inside a
training loop (`training`) a signal only asks the loop to stop: it finishes
the step in flight, saves a checkpoint and raises `Preempted`, so a relaunch
of the same command resumes at that step and logs every step once. Outside
a loop (loading data, compiling, evaluating) there is nothing newer than the
last checkpoint, and `Preempted` is raised at once. The entry point reports
it as one line and exits with 128 + the signal's number, as a shell does.
"""
import contextlib
import signal

SIGNALS = (signal.SIGTERM, signal.SIGINT)


class Preempted(Exception):
  """A run stopped by a signal; `exit_code` is 128 + its number."""

  def __init__(self, signum: int, where: str):
    self.exit_code = 128 + signum
    super().__init__(f"stopped by {signal.Signals(signum).name} {where}; relaunch the same "
                     "command to resume")


_state = {"in_loop": False, "signal": None}


def _handle(signum, frame):
  del frame
  if _state["in_loop"]:
    _state["signal"] = signum  # the loop saves and stops after this step
  else:
    raise Preempted(signum, "outside a training loop (the last checkpoint is kept)")


@contextlib.contextmanager
def handled():
  """SIGTERM and SIGINT stop the run inside this block (main thread only)."""
  previous = {s: signal.signal(s, _handle) for s in SIGNALS}
  _state.update(in_loop=False, signal=None)
  try:
    yield
  finally:
    for s, h in previous.items():
      signal.signal(s, h)


@contextlib.contextmanager
def training():
  """Marks a training loop: a signal then waits for `requested()`."""
  _state.update(in_loop=True)
  try:
    yield
  finally:
    _state.update(in_loop=False)


def requested():
  """The number of the signal that asked the loop to stop, or None."""
  return _state["signal"]
