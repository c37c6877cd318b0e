"""Your own photos (halo_jax/datasets/capture.py): a COLMAP model, nerfstudio's
transforms.json, or a folder of photos that structure-from-motion poses first.

  halo-train --config=capture.py:8view --config.data.root=DIR --workdir=RUN

Variants (the string after the colon): '<k>view' (a 360-degree capture, sphere
rays) or '<k>view_ff' (forward-facing, NDC rays); then '_cpu' for CPU-sized
models and a time budget (the method is --method's, HALO by default). The k training cameras are chosen by farthest point sampling on the
camera centres; every other registered camera is held out.
"""
from halo_jax import config_files, defaults

CPU_BUDGET_S = 600.0


def get_config(arg: str = "8view"):
  parts, flags = config_files.split_flags(arg, flags=("cpu", "ff"))
  if len(parts) != 1 or not parts[0].endswith("view") or not parts[0][:-4].isdigit():
    raise ValueError(f"unknown variant {arg!r}: use <k>view[_ff][_cpu], e.g. 8view")
  k = int(parts[0][:-4])
  c = defaults.base_config()
  c.data.update(kind="capture_ff" if "ff" in flags else "capture", root="", factor=1,
                train_views=f"farthest:{k}", test_views="all", white_background=False)
  if "cpu" in flags:
    defaults.cpu_sized(c, CPU_BUDGET_S)
  if "ff" in flags:  # the scene fills the frame: no centre crop
    c.lo.precrop_steps = 0
    c.hi.precrop_steps = 0
  return c
