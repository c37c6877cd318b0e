"""The command-line entry points, one module per console script:

  halo-train    halo_jax/cli/train.py     train a method's stages
  halo-eval     halo_jax/cli/evaluate.py  score a finished stage on a split
  halo-render   halo_jax/cli/render.py    videos along a camera path
  halo-compare  halo_jax/cli/compare.py   every method on one scene, equal time
  halo-sweep    halo_jax/cli/sweep.py     a grid of config overrides

Each is also `python -m halo_jax.cli.<name>`. Nothing below this package
imports it. The commands that take a --config take the method apart from it
(--method, or --methods for halo-compare): the config file names a scene,
halo_jax/configure.py makes it into the method.
"""
import contextlib

from absl import flags, logging
from ml_collections import config_flags

from halo_jax import config_files, configure, methods, user_errors, workdir_lock


def define_method_flag():
  """--method, for the commands that train one method from --config."""
  flags.DEFINE_enum("method", "halo", sorted(methods.METHODS.names()),
                    "The method trained on --config's scene (halo_jax/methods).")


def define_config_flag(help_string: str = "Scene config (path[:variant])."):
  """--config: a scene config file, with its dotted overrides as
  --config.<field>=VALUE (ml_collections parses and type-checks them)."""
  config_flags.DEFINE_config_file("config", None, help_string, lock_config=True)


def config_of_flags(config_flag, method: str):
  """--config's scene, read by configure.load_scene (the one loader of every
  entry point) with --config's dotted overrides set, made into `method`, with
  the overrides set again after the method, so that an override wins over
  what the method sets. config_flag: FLAGS['config']."""
  overrides = config_files.dotted_fields(config_flags.get_override_values(config_flag))
  scene = configure.load_scene(config_flags.get_config_filename(config_flag))
  for field, value in overrides.items():  # the scene a method reads, as overridden
    configure.set_field(scene, field, value)
  return configure.as_method(scene, method, overrides)


@contextlib.contextmanager
def launch(workdir: str = ""):
  """One command's launch, the same for every command: absl's logging quieted
  (orbax logs every save at INFO), bad input reported as one line and exit 2
  instead of a traceback, and `workdir`, where given, locked for the launch
  (a command that trains locks through pipeline.run instead)."""
  logging.set_verbosity(logging.WARNING)
  lock = workdir_lock.hold(workdir) if workdir else contextlib.nullcontext()
  with user_errors.reported(), lock:
    yield
