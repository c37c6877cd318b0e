"""Blender (NeRF-synthetic) scenes: the paper's 8-view and one-side protocols.

Variants (the string after the colon):
  <scene>_8view        paper protocol, 400x400 (factor 2), all 200 test views
  <scene>_8view_cpu    100x100 (factor 8), test views r_0, r_8, ..., r_192,
                       CPU-sized models and a wall-clock budget (docs/benchmark.md)
  lego_oneside[_cpu]   the 14 one-side lego views (Lo-P.E. L=5, s=1)
  lego_all[_cpu]       all 100 training views (the upper reference)
The method is chosen apart from the scene (`--method=freenerf`, default
halo; halo_jax.methods, docs/baselines.md).

The scene folder defaults to $HALO_DATA/nerf_synthetic/<scene> with HALO_DATA
defaulting to ./data; override with --config.data.root=PATH.
"""

from halo_jax import config_files, defaults

# The paper's table "Training images for the 8 view setting".
EIGHT_VIEWS = {
    "lego": "r_2 r_16 r_93 r_55 r_73 r_86 r_26 r_75",
    "chair": "r_86 r_73 r_26 r_2 r_55 r_93 r_16 r_75",
    "drums": "r_86 r_93 r_75 r_26 r_55 r_73 r_16 r_2",
    "ficus": "r_2 r_93 r_73 r_86 r_75 r_26 r_55 r_16",
    "mic": "r_55 r_2 r_93 r_75 r_16 r_26 r_86 r_73",
    "ship": "r_55 r_93 r_26 r_75 r_16 r_33 r_73 r_86",
    "materials": "r_75 r_26 r_93 r_55 r_86 r_16 r_2 r_73",
    "hotdog": "r_16 r_93 r_75 r_86 r_2 r_55 r_73 r_26",
}
ONE_SIDE_LEGO = "r_58 r_5 r_2 r_8 r_9 r_10 r_16 r_34 r_35 r_40 r_52 r_53 r_54 r_60"
CPU_BUDGET_S = 600.0


def get_config(arg: str = "lego_8view"):
  parts, flags = config_files.split_flags(arg)
  cpu = "cpu" in flags
  scene, setting = parts[0], "_".join(parts[1:])
  c = defaults.base_config()
  c.data.kind = "blender"
  c.data.root = defaults.data_root("nerf_synthetic", scene)
  if setting == "8view":
    if scene not in EIGHT_VIEWS:
      raise ValueError(f"no 8-view list for scene {scene!r}; known: {sorted(EIGHT_VIEWS)}")
    c.data.train_views = ",".join(EIGHT_VIEWS[scene].split())
  elif setting == "oneside" and scene == "lego":
    c.data.update(train_views=",".join(ONE_SIDE_LEGO.split()), protocol="lego_oneside")
    c.lo.encoding.scale = 1.0   # the paper's Lo-P.E. for these views: L=5, s=1
  elif setting == "all":
    c.data.train_views = "all"
  else:
    raise ValueError(f"unknown variant {arg!r}: use <scene>_8view, lego_oneside or "
                     "<scene>_all, optionally with _cpu")
  if cpu:
    c.data.factor = 8
    c.data.test_views = "every:8"
    defaults.cpu_sized(c, CPU_BUDGET_S)
  return c
