"""D-NeRF dynamic scenes: time as a low-frequency input (docs/scene_kinds.md).

Variants (the string after the colon), for any D-NeRF scene by name
(lego, hook, jumpingjacks, mutant, standup, trex, bouncingballs, hellwarrior):
  <scene>        the paper's few-shot protocol: 400x400 (factor 2) on white,
                 every 8th training frame, the 20 test frames, full-size models
  <scene>_cpu    the same frames at 100x100 (factor 8) on white, CPU-sized
                 models and a wall-clock budget
  tiny[_cpu]     lego from the packed 100x100 copy on black
                 ($HALO_DATA/dnerf/tiny_dnerf_data.npz)
The method is chosen apart (`--method`, halo_jax.methods): nerf_tuned is the
same dynamic Hi model trained alone, without the Lo model's regulariser.

Lo and Hi are deformation fields, Lo with low frequencies in x and t, Hi
with high ones; HALO on these scenes (no ray field) is in methods/halo.py.

Scene folders default to $HALO_DATA/dnerf/<scene> (HALO_DATA defaults to
./data); override with --config.data.root=PATH.
"""

from halo_jax import config_files, defaults

CPU_BUDGET_S = 600.0


def _dynamic(c):
  """Both NeRF stages become deformation fields of (x, t)."""
  for name in ("lo", "hi"):
    c[name].model.kind = "deform"
    c[name].model.use_viewdirs = False  # Lo has none; the scenes are nearly diffuse
  # The authors lower TiNeuVox's P.E. to 4 for x and 4 for t in Lo (Hi: 10 and 8).
  c.lo.encoding.update(L=4, scale=1.0, time_L=4)
  c.hi.encoding.update(L=10, scale=1.0, time_L=8)
  # Lo's samples for Hi and for the baseline alike (no ray field places them).
  c.hi.sampler.num_samples = c.lo.sampler.num_samples
  c.baseline.num_samples = c.hi.sampler.num_samples
  return c


def _data_root(scene):
  return defaults.data_root("dnerf", "tiny_dnerf_data.npz" if scene == "tiny" else scene)


def get_config(arg: str = "lego"):
  parts, flags = config_files.split_flags(arg)
  cpu = "cpu" in flags
  if len(parts) != 1:
    raise ValueError(f"unknown variant {arg!r}: use <scene>[_cpu] (a D-NeRF scene name) or "
                     "tiny[_cpu]")
  scene = parts[0]
  c = defaults.base_config()
  c.data.update(kind="dnerf", train_views="every:8", test_views="all", root=_data_root(scene))
  if scene == "tiny":  # the packed copy: 100x100, composited on black
    c.data.update(factor=1, white_background=False)
  else:
    c.data.update(factor=8 if cpu else 2, white_background=True)
  # TiNeuVox-S: 20k steps of 4096 rays for the model HALO regularises.
  c.lo.update(steps=20000, batch_rays=4096)
  c.hi.update(steps=20000, batch_rays=4096)
  if cpu:
    defaults.cpu_sized(c, CPU_BUDGET_S)
    for name in ("lo", "hi"):
      c[name].model.update(deform_width=64, deform_depth=3)
  _dynamic(c)
  c.eval.chunk = 10000
  return c
