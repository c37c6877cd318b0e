"""LLFF forward-facing scenes in NDC: the paper's 4-view protocol.

Variants (the string after the colon):
  fern_4view       train on 005 013 015 016, test on 014, images_8 (504x378),
                   the paper's step counts (HALO's protocol)
  fern_4view_cpu   the same views, CPU-sized models and a wall-clock budget
  <scene>_3view, _6view, _9view
                   RegNeRF's split, the field's standard sparse LLFF protocol:
                   every 8th image held out, 3 / 6 / 9 training views spread
                   over the rest (any of the eight scenes; _cpu as above)
The method is chosen apart (`--method`, halo_jax.methods): `halo_joint` is
the paper's joint scheme (the ray field trained with Hi-NeRF), `nerf_tuned`
the Hi model alone with stratified samples.
Other scenes: --config.data.root=.../nerf_llff_data/<scene> with your own
--config.data.train_views / test_views (the paper's lists for flower, leaves
and orchids are in FOUR_VIEWS).

HALO here is the two-stage scheme (methods/halo.py, NDC rays): without
the empty-space loss and the ray field's random rays, which forward-facing
data does not need.

The scene folder defaults to $HALO_DATA/nerf_llff_data/<scene>.
"""

from halo_jax import config_files, defaults

# The paper's table "Four training views and one validation view on LLFF".
FOUR_VIEWS = {
    "fern": ("005,013,015,016", "014"),
    "flower": ("007,008,011,009", "010"),
    "leaves": ("004,005,008,006", "007"),
    "orchids": ("008,006,014,015", "007"),
}
# RegNeRF's protocol, which FreeNeRF, SparseNeRF and the Gaussian-splatting
# few-shot papers report on: every 8th image held out for testing, and 3, 6
# or 9 training views spread over the rest (datasets.spread_views).
SCENES = ("fern", "flower", "fortress", "horns", "leaves", "orchids", "room", "trex")
REGNERF_VIEWS = ("3view", "6view", "9view")
REGNERF_HOLD = 8
CPU_BUDGET_S = 600.0


def _views(scene, setting, arg):
  """(train_views, test_views) of a variant's setting."""
  if setting == "4view" and scene in FOUR_VIEWS:
    return FOUR_VIEWS[scene]
  if setting in REGNERF_VIEWS and scene in SCENES:
    return f"spread:{setting[0]}/{REGNERF_HOLD}", f"every:{REGNERF_HOLD}"
  raise ValueError(f"unknown variant {arg!r}: use <scene>_4view[_cpu] with scene in "
                   f"{sorted(FOUR_VIEWS)}, or <scene>_{{3,6,9}}view[_cpu] with scene "
                   f"in {list(SCENES)}")


def get_config(arg: str = "fern_4view"):
  parts, flags = config_files.split_flags(arg)
  cpu = "cpu" in flags
  if len(parts) != 2:
    _views("", "", arg)
  scene = parts[0]
  c = defaults.base_config()
  train, test = _views(scene, parts[1], arg)
  c.data.update(kind="llff", factor=8, train_views=train, test_views=test,
                white_background=False, near=0.0, far=1.0,
                root=defaults.data_root("nerf_llff_data", scene))
  if cpu:
    defaults.cpu_sized(c, CPU_BUDGET_S)
    c.eval.chunk = 8192
  c.lo.precrop_steps = 0            # forward-facing: the scene fills the frame
  c.hi.precrop_steps = 0
  c.hi.joint.alpha_steps = 500 if cpu else 20000  # the joint sampler's window schedule
  return c
