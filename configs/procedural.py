"""The built-in procedural scenes (halo_jax/datasets/procedural.py), no download.

Variants (the string after the colon):
  <scene>_8view       eight training views, 25 test views on the 30-degree
                      orbit, 200x200 images, full-size models
  <scene>_8view_cpu   the same views at 100x100, CPU-sized models and a
                      wall-clock budget
with <scene> one of procedural.SCENES: `spheres` (cameras all round) or
`lattice` (thin rods round a small core, training cameras on one side).
The method is chosen apart (`--method`, halo_jax.methods). The scene is
generated into the workdir on first use.
"""
from halo_jax import config_files, defaults
from halo_jax.datasets import procedural

EIGHT_VIEWS = "r_0,r_13,r_26,r_39,r_52,r_65,r_78,r_91"
CPU_BUDGET_S = 600.0


def get_config(arg: str = "lattice_8view_cpu"):
  parts, flags = config_files.split_flags(arg)
  if len(parts) != 2 or parts[0] not in procedural.SCENES or parts[1] != "8view":
    raise ValueError(f"unknown variant {arg!r}: use <scene>_8view[_cpu] with scene in "
                     f"{sorted(procedural.SCENES)}")
  c = defaults.base_config()
  c.data.update(kind="procedural", procedural_scene=parts[0], factor=1,
                train_views=EIGHT_VIEWS, test_views="every:8")
  c.data.procedural_size = 200
  if "cpu" in flags:
    c.data.procedural_size = 100
    defaults.cpu_sized(c, CPU_BUDGET_S)
  return c
