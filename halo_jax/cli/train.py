"""Launches HALO's stages.

  python -m halo_jax.cli.train --config=configs/blender.py:lego_8view \
      --workdir=DIR [--method=freenerf] --config.data.root=PATH [--config.stages=lo,ray,hi]

This file is kept short: the logic lives in `halo_jax.pipeline`.
"""
import json

from absl import flags

from halo_jax import parallel, pipeline
from halo_jax.cli import run_app, config_of_flags, define_config_flag, define_method_flag, launch, view

FLAGS = flags.FLAGS
define_config_flag()
flags.DEFINE_string("workdir", None, "Folder for checkpoints, logs and renders.")
flags.DEFINE_bool("view", False, "Also open halo-view on the run, in a process of its own.")
flags.DEFINE_integer("view_port", 8080, "The viewer's port (with --view).")
define_method_flag()
flags.mark_flags_as_required(["config", "workdir"])


def main(argv):
  del argv
  with launch():
    if FLAGS.view:
      view.check_port("127.0.0.1", FLAGS.view_port)
      view.launch_beside(FLAGS.workdir, FLAGS.view_port)
    config = config_of_flags(FLAGS["config"], FLAGS.method)
    parallel.initialize(config.parallel)
    infos = pipeline.run(config, FLAGS.workdir)
  print(pipeline.table(infos))
  print(json.dumps({"workdir": FLAGS.workdir}))


def cli():
  """The halo-train console script."""
  run_app(main)


if __name__ == "__main__":
  cli()
