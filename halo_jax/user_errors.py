"""The errors a user's input or a run that cannot progress raises, and how an
entry point reports them: one line on stderr, a non-zero exit, no traceback.
A traceback means a bug in halo-jax, not in the input."""
import contextlib
import gc
import os
import sys

import jax

from halo_jax.datasets.base import DataError
from halo_jax.registry import ConfigError
from halo_jax.restore import NothingToRestore
from halo_jax.stages.collapse import Collapsed
from halo_jax.stages.loop import NonFiniteError
from halo_jax.stages import preemption
from halo_jax.stages.preemption import Preempted
from halo_jax.stages.state import StageMissing
from halo_jax.stages.workdir import WorkdirMismatch
from halo_jax.workdir_lock import DISK_ERRNOS, WorkdirLocked, WorkdirUnwritable, unwritable

USER_ERRORS = (Collapsed, ConfigError, DataError, NonFiniteError, NothingToRestore, StageMissing,
               WorkdirLocked, WorkdirMismatch, WorkdirUnwritable)
EXIT_CODE = 2
LOST_PEER_EXIT_CODE = 3


@contextlib.contextmanager
def reported():
  """Turns a USER_ERRORS exception into `error: <message>` on stderr and exit
  2, a run stopped by a signal (stages.preemption) into one line and exit
  128 + its number, and a collective that failed in a multi-process job (a
  peer died) into one line and exit 3."""
  disk_error = None
  try:
    with preemption.handled():
      yield
  except Preempted as e:
    print(f"error: {e}", file=sys.stderr, flush=True)
    raise SystemExit(e.exit_code) from None
  except USER_ERRORS as e:
    print(f"error: {e}", file=sys.stderr)
    raise SystemExit(EXIT_CODE) from None
  except OSError as e:
    if e.errno not in DISK_ERRNOS:
      raise
    disk_error = str(unwritable(None, e))
  except jax.errors.JaxRuntimeError as e:
    if jax.process_count() <= 1:
      raise
    first = str(e).strip().splitlines()[0][:300]
    print(f"error: process {jax.process_index()} of {jax.process_count()}: a step across "
          f"processes failed ({first}); another process of the job has probably died. "
          "Relaunch the job: it resumes from the last checkpoint.", file=sys.stderr, flush=True)
    # Leave at once: a normal exit waits at JAX's shutdown barrier for the dead
    # peer and then aborts with a C++ stack trace.
    os._exit(LOST_PEER_EXIT_CODE)  # pylint: disable=protected-access
  if disk_error is not None:  # out of the except clause: its traceback is let go
    print(f"error: {disk_error}", file=sys.stderr)
    _collect_quietly()
    raise SystemExit(EXIT_CODE)


def _collect_quietly():
  """Collects the objects a failed write left open, whose finalisers would
  fail on the same full disk and print tracebacks at exit."""
  hook = sys.unraisablehook
  sys.unraisablehook = lambda unraisable: None
  try:
    gc.collect()
  finally:
    sys.unraisablehook = hook
