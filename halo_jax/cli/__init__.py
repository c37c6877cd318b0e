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
from absl import flags, logging
from ml_collections import config_flags

from halo_jax import configure, methods, user_errors, workdir_lock


def define_method_flag():
  """--method, for the commands that train one method from --config."""
  flags.DEFINE_enum("method", "halo", sorted(methods.METHODS.names()),
                    "The method trained on --config's scene (halo_jax/methods).")


def config_of_flags(config_flag, method: str):
  """--config's scene made into `method`, with --config's dotted overrides
  set again after the method (config_flags set them on the scene, before the
  method existed), so that an override wins over what the method sets.
  config_flag: FLAGS['config']."""
  overrides = configure.dotted_fields(config_flags.get_override_values(config_flag))
  return configure.as_method(config_flag.value, method, overrides)


def run_in_workdir(run, config, workdir: str):
  """run(config) as one launch of an experiment in `workdir`: absl's logging
  quieted, the workdir locked for the launch, and bad input reported as one
  line and exit 2, not a traceback."""
  logging.set_verbosity(logging.WARNING)
  with user_errors.reported(), workdir_lock.hold(workdir):
    run(config)
