"""HALO for nerfbaselines from a virtual environment that already has
halo-jax, with no conda.

nerfbaselines (1.2) pins numpy below 2, which today's jax does not take, so
the two cannot share an environment. Its conda backend solves this by
running the method in an environment of its own and calling it over RPC;
this module does the same with an existing Python (HALO_JAX_PYTHON, e.g.
halo-jax's .venv/bin/python): nerfbaselines' own RemoteProcessRPCBackend
starts its worker with that Python, and `HaloInVenv`, which nerfbaselines
runs on its `python` backend, forwards every Method call to the
HaloMethod built there. Loaded in nerfbaselines' process: imports no jax.
"""
import hashlib
import importlib
import os
import sys
import tempfile

from nerfbaselines.backends import _rpc

METHOD_CLASS = "halo_jax.integrations.nerfbaselines_method:HaloMethod"


def halo_python() -> str:
  """The Python of the environment that has halo-jax (HALO_JAX_PYTHON)."""
  python = os.environ.get("HALO_JAX_PYTHON", "")
  if not python or not os.access(python, os.X_OK):
    raise RuntimeError(f"HALO_JAX_PYTHON={python!r}: set it to the python of an environment "
                       "with halo-jax installed (e.g. .venv/bin/python of a clone)")
  return python


def _nerfbaselines_only_path() -> str:
  """A folder holding only a link to the nerfbaselines package, for the
  worker's PYTHONPATH: the folder it is installed in would also put this
  environment's numpy ahead of the worker's own (as nerfbaselines' conda
  backend does it)."""
  import nerfbaselines  # pylint: disable=g-import-not-at-top
  package = os.path.dirname(os.path.abspath(nerfbaselines.__file__))
  key = hashlib.sha256(package.encode()).hexdigest()[:16]
  folder = os.path.join(tempfile.gettempdir(), "halo-nerfbaselines-sources", key)
  os.makedirs(folder, exist_ok=True)
  link = os.path.join(folder, "nerfbaselines")
  if not os.path.exists(link):
    os.symlink(package, link)
  return folder


def read_numpy2_pickles() -> None:
  """Lets this process (numpy 1, nerfbaselines' pin) unpickle the worker's
  arrays: numpy 2 pickles them by its `numpy._core.<module>` names, which
  numpy 1 has as `numpy.core.<module>` (its own `numpy._core` is a stub)."""
  import numpy  # pylint: disable=g-import-not-at-top
  if int(numpy.__version__.split(".")[0]) >= 2:
    return
  for name in ("numeric", "multiarray", "_multiarray_umath", "umath", "_internal", "_dtype"):
    try:
      sys.modules.setdefault(f"numpy._core.{name}", importlib.import_module(f"numpy.core.{name}"))
    except ImportError:
      pass


class VenvBackend(_rpc.RemoteProcessRPCBackend):
  """nerfbaselines' RPC worker, started with another environment's Python."""
  name = "halo-venv"

  def __init__(self, python: str):
    read_numpy2_pickles()
    super().__init__(python_path=python)
    self._python = python

  def __enter__(self):
    # Started, but not made this thread's current backend: nerfbaselines
    # sends `run_on_host` functions (its metrics) to the current backend,
    # and those belong in nerfbaselines' process, not in halo-jax's.
    self._inside_context = True
    return self

  def __exit__(self, exc_type, exc_val, exc_tb):
    self._inside_context = False
    self.close(_force=isinstance(exc_val, (ConnectionError, BrokenPipeError, OSError,
                                           TimeoutError)))

  def _launch_worker(self, args, env):
    env = dict(env)
    env["PATH"] = os.path.dirname(self._python) + os.pathsep + env.get("PATH", "")
    env["PYTHONPATH"] = _nerfbaselines_only_path()
    env.pop("VIRTUAL_ENV", None)
    args = [self._python] + list(args[1:])  # args[0] is "python"
    return super()._launch_worker(args, env)


class HaloInVenv:
  """A nerfbaselines Method whose calls run in HALO_JAX_PYTHON's environment."""

  def __init__(self, *, checkpoint=None, train_dataset=None, config_overrides=None):
    self._backend = VenvBackend(halo_python())
    self._backend.__enter__()
    try:
      from nerfbaselines import _method_utils  # pylint: disable=g-import-not-at-top
      cls = self._backend.static_call(
          f"{_method_utils.__name__}:_build_method_class_internal",
          {"id": "halo", "method_class": METHOD_CLASS})
      self._inner = cls(checkpoint=checkpoint, train_dataset=train_dataset,
                        config_overrides=config_overrides)
    except BaseException:
      self._backend.__exit__(*sys.exc_info())
      raise

  @classmethod
  def get_method_info(cls):
    from halo_jax.integrations import nerfbaselines_info  # pylint: disable=g-import-not-at-top
    return nerfbaselines_info.method_info()

  def get_info(self):
    return self._inner.get_info()

  def train_iteration(self, step):
    return self._inner.train_iteration(step)

  def render(self, camera, *, options=None):
    return self._inner.render(camera, options=options)

  def save(self, path):
    return self._inner.save(path)

  def get_train_embedding(self, index):
    del index
    return None

  def close(self):
    """Stops the worker."""
    backend, self._backend = getattr(self, "_backend", None), None
    if backend is not None:
      backend.__exit__(None, None, None)

  def __del__(self):
    self.close()
