"""Two-plane light fields in the Stanford Light Field Archive layout.

Files `out_RR_CC_<Y>_<X>.(jpg|png)`: RR, CC the row and column on the camera
grid (17x17 for the archive). Coordinates (docs/scene_kinds.md), all in [-1, 1]:
  u, v: camera-plane position from the grid column and row, sign * (CC - c) / c
        with c the grid centre (8 for 17x17) and the signs `grid_signs`;
  s, t: image-plane position of the pixel centre, (x + 0.5) / W * 2 - 1.
A scene point seen at s in view u is seen at s - (u - u') delta in view u',
with delta = cot(theta) its EPI slope (normalised disparity); the data
config's disparity range, in pixels per grid step at the files' resolution,
sets the bounds [theta_n, theta_f] every ray is sampled in.

Order matters: rays are composited from theta_n (largest delta) to theta_f,
so the largest delta must be the nearest point. That holds when u and v grow
in the direction the camera moves in image x and y; in the Stanford archive
the camera moves the other way as the column and row grow (the file names'
X and Y fall), hence grid_signs = (-1, -1) by default.
`tests/test_lightfield.py` checks it on knights by photo-consistency: the
knights, which stand in front of the wall, must get the larger delta.
"""
import dataclasses
import os
import re
from typing import Tuple

import numpy as np

from halo_jax.datasets import blender
from halo_jax.datasets.base import DataError

_NAME = re.compile(r"^out_(\d+)_(\d+)_.*\.(jpg|jpeg|png)$", re.IGNORECASE)


@dataclasses.dataclass(frozen=True)
class LightFieldViews:
  """Sub-aperture images of a two-plane light field.

  Attributes:
    images: [N, H, W, 3] float32 in [0, 1].
    uv: [N, 2] camera-plane coordinates in [-1, 1].
    names: N names 'RR_CC'.
  """
  images: np.ndarray
  uv: np.ndarray
  names: Tuple[str, ...]
  times = None

  @property
  def height(self) -> int:
    return self.images.shape[1]

  @property
  def width(self) -> int:
    return self.images.shape[2]

  def rays(self):
    """Every pixel's ray as origin (u, v, 0) and 'direction' (s, t, 1), each
    [N, H, W, 3]: the two-plane ray in the shape every renderer takes."""
    n, h, w = self.images.shape[:3]
    s = (np.arange(w, dtype=np.float32) + 0.5) / w * 2 - 1
    t = (np.arange(h, dtype=np.float32) + 0.5) / h * 2 - 1
    st = np.stack(np.meshgrid(s, t, indexing="xy"), -1)               # [H, W, 2]
    o = np.concatenate([np.broadcast_to(self.uv[:, None, None], (n, h, w, 2)),
                        np.zeros((n, h, w, 1), np.float32)], -1)
    d = np.concatenate([np.broadcast_to(st, (n, h, w, 2)), np.ones((n, h, w, 1), np.float32)],
                       -1)
    return o.astype(np.float32), d.astype(np.float32)

  def ray_times(self):
    return None


def scan(root: str):
  """{'RR_CC': path} of every grid image in `root`, and the grid size (rows, cols)."""
  if not os.path.isdir(root):
    raise DataError(f"{root}: light-field folder not found (data.root)")
  found = {}
  for f in sorted(os.listdir(root)):
    m = _NAME.match(f)
    if m:
      found[(int(m.group(1)), int(m.group(2)))] = os.path.join(root, f)
  if not found:
    raise DataError(f"{root}: no files named out_RR_CC_*.jpg|png (Stanford archive layout)")
  rows = 1 + max(r for r, _ in found)
  cols = 1 + max(c for _, c in found)
  return {f"{r:02d}_{c:02d}": p for (r, c), p in found.items()}, (rows, cols)


def load_views(root: str, names, factor: int = 1, grid_signs=(-1.0, -1.0)) -> LightFieldViews:
  """Loads the named grid views ('RR_CC'), downscaled by `factor`; u, v are
  the column and row offsets from the grid centre times `grid_signs`."""
  files, (rows, cols) = scan(root)
  missing = [n for n in names if n not in files]
  if missing:
    raise DataError(f"{root}: views {missing} named in the config are not in the grid")
  images, uv = [], []
  for n in names:
    img = blender.load_image(files[n], factor, white_background=False)
    if images and img.shape != images[0].shape:
      raise DataError(f"{files[n]}: size {img.shape[1]}x{img.shape[0]} (after factor {factor}) "
                      f"differs from {images[0].shape[1]}x{images[0].shape[0]} of the other views")
    r, c = (int(x) for x in n.split("_"))
    uv.append([grid_signs[0] * (c - (cols - 1) / 2) / ((cols - 1) / 2),
               grid_signs[1] * (r - (rows - 1) / 2) / ((rows - 1) / 2)])
    images.append(img)
  return LightFieldViews(np.stack(images), np.asarray(uv, np.float32), tuple(names))


def theta_bounds(disparity_px, width_px: int, grid_cols: int):
  """[theta_n, theta_f] from a disparity range in pixels per grid step.

  delta = px * (2 / W) / (2 / (cols - 1)) per unit u; theta = atan2(1, delta),
  so the nearest point (largest delta) has the smallest theta.
  """
  lo, hi = (float(x) for x in disparity_px)
  if not lo < hi:
    raise DataError(f"data.disparity_px={tuple(disparity_px)} must be (min, max) with min < max")
  per_unit = (2.0 / width_px) * (grid_cols - 1) / 2.0
  return float(np.arctan2(1.0, hi * per_unit)), float(np.arctan2(1.0, lo * per_unit))


def names_of(spec, root):
  files, _ = scan(root)
  if spec in (None, "all"):
    return sorted(files)
  return [s.strip() for s in (spec.split(",") if isinstance(spec, str) else spec) if s.strip()]
