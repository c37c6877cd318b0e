"""The default job: the built-in lattice scene (no download), CPU-sized.

  halo-compare --config=configs/default.py --workdir=/tmp/halo_default
  python -m halo_jax.cli.train --config=configs/default.py --workdir=/tmp/halo_run

Eight rods of 0.035 radius and two thin bars round a small checkered core, in
a large empty volume (halo_jax/datasets/procedural.py, 'lattice'): eight
training views from one side of the object only, 100x100; 13 held-out views
on the full 30-degree orbit, so half of them look at sides no training view
saw. Few views leave this scene underconstrained, which is what HALO repairs:
a NeRF fills the empty volume with floaters. 50 s of training per method, so
that the five methods fit in ten minutes on 2 CPU cores.
"""
from halo_jax import defaults


def get_config():
  """The scene; the method is chosen apart (--method, halo_jax/configure.py)."""
  c = defaults.base_config()
  c.data.update(kind="procedural", procedural_scene="lattice", factor=1,
                train_views="r_0,r_13,r_26,r_39,r_52,r_65,r_78,r_91", test_views="every:16")
  c.data.procedural_size = 100
  defaults.cpu_sized(c, budget_s=50.0)
  c.eval.curve_views = 2
  return c
