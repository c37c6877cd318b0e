"""The default job: the built-in procedural scene (no download), CPU-sized.

  python experiments/few_shot.py --config=configs/default.py --workdir=/tmp/halo_default
  python -m halo_jax.main --config=configs/default.py --workdir=/tmp/halo_run

Eight training views (cameras on the upper hemisphere), 25 held-out views on a
30-degree orbit, 100x100 images, 150 s of training per method.
"""
from halo_jax import defaults


def get_config():
  c = defaults.base_config()
  c.data.kind = "procedural"
  c.data.factor = 1
  c.data.train_views = "r_0,r_13,r_26,r_39,r_52,r_65,r_78,r_91"
  c.data.test_views = "every:8"
  defaults.cpu_sized(c, budget_s=150.0)
  return c
