"""The default job: the built-in lattice scene (no download), CPU-sized.

  halo-compare --config=configs/default.py --workdir=/tmp/halo_default
  python -m halo_jax.cli.train --config=configs/default.py --workdir=/tmp/halo_run

procedural.py's `lattice_8view_cpu` (eight rods of 0.035 radius and two thin
bars round a small checkered core in a large empty volume, eight training
views from one side, 100x100), with every 16th orbit view held out (13
views, half of them on sides no training view saw) and a budget of 50
reference seconds per method (halo_jax/protocol.py), so that the five
methods fit in a few minutes on 2 CPU cores.
"""
from halo_jax import protocol
from halo_jax.configs import procedural


def get_config():
  """The scene; the method is chosen apart (--method, halo_jax/configure.py)."""
  c = procedural.get_config("lattice_8view_cpu")
  c.data.test_views = "every:16"
  c.eval.curve_views = 2
  return protocol.budget(c, 50.0)
