"""One process per workdir: an OS file lock taken at launch.

The lock is `fcntl.flock` on `<workdir>/.lock`, so the kernel releases it when
the holder exits, however it exits (a `kill -9` leaves nothing stale). The
file records the holder's pid, host and command line, which a refused launch
prints.
"""
import contextlib
import errno
import fcntl
import os
import socket
import sys

LOCK_FILE = ".lock"


class WorkdirLocked(RuntimeError):
  """Another live process holds the workdir."""


class WorkdirUnwritable(RuntimeError):
  """The workdir cannot be written: a read-only place, no permission, a full disk."""


# Errors of the file system rather than of halo-jax: a full disk mid-run is
# reported as one line too (user_errors).
DISK_ERRNOS = frozenset({errno.ENOSPC, errno.EDQUOT, errno.EROFS, errno.EACCES, errno.EPERM})


def unwritable(workdir, e: OSError) -> WorkdirUnwritable:
  """The one-line error for a write that failed (under `workdir`, where known)."""
  where = e.filename or workdir
  where = f"{where}: cannot write" if where else "a write to disk failed"
  return WorkdirUnwritable(f"{where} ({e.strerror}); free space there or use another "
                           "--workdir (a relaunch resumes from the last checkpoint)")


@contextlib.contextmanager
def hold(workdir: str):
  """Holds `workdir`'s lock for the block; WorkdirLocked at once if another
  process holds it. Re-entrant within one process (nested holds of one
  workdir, e.g. a driver and the pipeline it calls, share the lock)."""
  path = os.path.abspath(os.path.join(workdir, LOCK_FILE))
  if path in _HELD:
    _HELD[path][1] += 1
    try:
      yield
    finally:
      _HELD[path][1] -= 1
    return
  try:
    os.makedirs(os.path.dirname(path), exist_ok=True)
    f = open(path, "a+")
  except OSError as e:
    raise unwritable(workdir, e) from None
  try:
    fcntl.flock(f, fcntl.LOCK_EX | fcntl.LOCK_NB)
  except BlockingIOError:
    f.seek(0)
    holder = f.read().strip() or "an unknown process"
    f.close()
    raise WorkdirLocked(f"{workdir} is in use by {holder}; wait for it to end or use "
                        f"another --workdir") from None
  f.seek(0)
  f.truncate()
  f.write(f"pid {os.getpid()} on host {socket.gethostname()} "
          f"({' '.join(sys.argv)[:200]})\n")
  f.flush()
  _HELD[path] = [f, 1]
  try:
    yield
  finally:
    _HELD[path][1] -= 1
    if _HELD[path][1] == 0:
      del _HELD[path]
      fcntl.flock(f, fcntl.LOCK_UN)
      f.close()


_HELD = {}


def is_held(workdir: str) -> bool:
  """Whether a process (a training run) holds `workdir`'s lock now; the
  probe takes no lock that outlives it."""
  path = os.path.abspath(os.path.join(workdir, LOCK_FILE))
  if path in _HELD:
    return True
  try:
    with open(path) as f:
      try:
        fcntl.flock(f, fcntl.LOCK_SH | fcntl.LOCK_NB)
      except BlockingIOError:
        return True
      fcntl.flock(f, fcntl.LOCK_UN)
      return False
  except OSError:
    return False
