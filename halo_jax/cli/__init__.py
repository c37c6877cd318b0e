"""The command-line entry points, one module per console script:

  halo-train    halo_jax/cli/train.py     train a method's stages
  halo-eval     halo_jax/cli/evaluate.py  score a finished stage on a split
  halo-render   halo_jax/cli/render.py    videos along a camera path
  halo-compare  halo_jax/cli/compare.py   every method on one scene, equal time
  halo-sweep    halo_jax/cli/sweep.py     a grid of config overrides

Each is also `python -m halo_jax.cli.<name>`. Nothing below this package
imports it.
"""
from absl import logging

from halo_jax import user_errors, workdir_lock


def run_in_workdir(run, config, workdir: str):
  """run(config) as one launch of an experiment in `workdir`: absl's logging
  quieted, the workdir locked for the launch, and bad input reported as one
  line and exit 2, not a traceback."""
  logging.set_verbosity(logging.WARNING)
  with user_errors.reported(), workdir_lock.hold(workdir):
    run(config)
