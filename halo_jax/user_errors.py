"""The errors a user's input or a run that cannot progress raises, and how an
entry point reports them: one line on stderr, a non-zero exit, no traceback.
A traceback means a bug in halo-jax, not in the input."""
import contextlib
import sys

from halo_jax.datasets.base import DataError
from halo_jax.registry import ConfigError
from halo_jax.stages.loop import NonFiniteError
from halo_jax.stages.state import StageMissing
from halo_jax.stages.workdir import WorkdirMismatch
from halo_jax.workdir_lock import WorkdirLocked

USER_ERRORS = (ConfigError, DataError, NonFiniteError, StageMissing, WorkdirLocked,
               WorkdirMismatch)
EXIT_CODE = 2


@contextlib.contextmanager
def reported():
  """Turns a USER_ERRORS exception into `error: <message>` on stderr and exit 2."""
  try:
    yield
  except USER_ERRORS as e:
    print(f"error: {e}", file=sys.stderr)
    raise SystemExit(EXIT_CODE) from None
