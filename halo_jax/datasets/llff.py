"""LLFF forward-facing scenes: poses_bounds.npy + images_<factor>/ (NeRF's loader).

poses_bounds.npy holds one row of 17 numbers per image (sorted by file
name): a 3x5 matrix (a camera-to-world 3x4 in LLFF's [down, right, back]
axes, then the column [H, W, focal] of the full-size images) and the near and
far scene depths. As in NeRF: axes become [right, up, back] (OpenGL), the
scene is scaled so the nearest bound is 1 / bd_factor (0.75), and poses are
recentred on their average pose. Rays are then converted to NDC (near plane
z = -1), where the scene spans t in [0, 1].

Views are named by their index in the sorted image list, three digits
('005'), as the paper lists them.
"""
import dataclasses
import os

import numpy as np

from halo_jax import camera
from halo_jax.datasets import blender
from halo_jax.datasets.base import DataError, Similarity, Views

BD_FACTOR = 0.75
_IMAGE_EXT = (".png", ".jpg", ".jpeg")


@dataclasses.dataclass(frozen=True)
class NDCViews(Views):
  """Views whose rays() are in NDC (forward-facing scenes)."""

  def rays(self):
    o, d = super().rays()
    return camera.ndc_rays(o, d, self.height, self.width, self.focal)


def _normalize(x):
  return x / np.linalg.norm(x)


def average_pose(c2w):
  """The mean camera: mean centre, mean viewing axis, mean up (NeRF's poses_avg). [3, 4]."""
  centre = c2w[:, :3, 3].mean(0)
  z = _normalize(c2w[:, :3, 2].sum(0))
  y_up = c2w[:, :3, 1].sum(0)
  x = _normalize(np.cross(y_up, z))
  y = np.cross(z, x)
  return np.stack([x, y, z, centre], 1)


def read_poses(root: str):
  """Recentred, rescaled camera-to-world [N, 4, 4], focal of the full-size
  images, their (H, W), and the rescaled bounds [N, 2]."""
  path = os.path.join(root, "poses_bounds.npy")
  if not os.path.exists(path):
    raise DataError(f"{path}: file not found (data.root={root!r})")
  try:
    raw = np.load(path)
  except Exception as e:  # a truncated or foreign file raises several types
    raise DataError(f"{path}: cannot read as .npy ({e})") from e
  if raw.ndim != 2 or raw.shape[1] != 17:
    raise DataError(f"{path}: shape {raw.shape}, expected (N, 17) (3x5 pose + 2 bounds)")
  if not np.all(np.isfinite(raw)):
    bad = int(np.flatnonzero(~np.isfinite(raw).all(1))[0])
    raise DataError(f"{path}: row {bad} is not finite")
  poses = raw[:, :15].reshape(-1, 3, 5).astype(np.float64)
  bounds = raw[:, 15:].astype(np.float64)
  if np.any(bounds <= 0):
    raise DataError(f"{path}: near/far bounds (last two columns) must be positive")
  hwf = poses[0, :, 4]
  # [down, right, back] -> [right, up, back]
  c2w = np.concatenate([poses[:, :, 1:2], -poses[:, :, 0:1], poses[:, :, 2:4]], 2)
  c2w, bounds = normalize_forward_facing(c2w, bounds)
  return c2w, float(hwf[2]), (int(hwf[0]), int(hwf[1])), bounds


def forward_frame(c2w, bounds) -> Similarity:
  """NeRF's LLFF normalisation of a forward-facing scene with OpenGL
  camera-to-world [N, 3 or 4, 4] and scene depth bounds [N, 2]: scaled so
  the nearest bound is 1 / BD_FACTOR, recentred on the average pose."""
  scale = 1.0 / (bounds.min() * BD_FACTOR)
  scaled = np.array(c2w[:, :3, :4], np.float64)
  scaled[:, :, 3] *= scale
  avg = np.linalg.inv(np.concatenate([average_pose(scaled), [[0, 0, 0, 1.0]]], 0))
  return Similarity(avg[:3, :3], float(scale), avg[:3, 3])


def normalize_forward_facing(c2w, bounds):
  """forward_frame applied: ([N, 4, 4] camera-to-world, [N, 2] bounds)."""
  frame = forward_frame(c2w, bounds)
  return frame.poses(c2w), bounds * frame.scale


def image_files(root: str, factor: int):
  folder = os.path.join(root, "images" if factor == 1 else f"images_{factor}")
  if not os.path.isdir(folder):
    raise DataError(f"{folder}: image folder not found (data.factor={factor})")
  files = sorted(f for f in os.listdir(folder) if f.lower().endswith(_IMAGE_EXT))
  return [os.path.join(folder, f) for f in files]


def split_names(root: str, factor: int):
  return [f"{i:03d}" for i in range(len(image_files(root, factor)))]


def load_views(root: str, factor: int, names) -> NDCViews:
  """The named views ('005', ...) of an LLFF scene from images_<factor>/."""
  c2w, focal_full, (h_full, w_full), _ = read_poses(root)
  files = image_files(root, factor)
  if len(files) != c2w.shape[0]:
    raise DataError(f"{os.path.dirname(files[0]) if files else root}: {len(files)} images but "
                    f"{c2w.shape[0]} rows in poses_bounds.npy")
  all_names = split_names(root, factor)
  missing = [n for n in names if n not in all_names]
  if missing:
    raise DataError(f"{root}: views {missing} named in the config are not in the "
                    f"{len(all_names)} images")
  idx = [all_names.index(n) for n in names]
  images = []
  for i in idx:
    img = blender.load_image(files[i], 1, white_background=False)
    if images and img.shape != images[0].shape:
      raise DataError(f"{files[i]}: size {img.shape[1]}x{img.shape[0]} differs from "
                      f"{images[0].shape[1]}x{images[0].shape[0]} of the other views")
    images.append(img)
  h, w = images[0].shape[:2]
  if abs(w * h_full - h * w_full) > max(h_full, w_full):  # allow rounding of the downscale
    raise DataError(f"{files[idx[0]]}: size {w}x{h} does not match the aspect of "
                    f"{w_full}x{h_full} in poses_bounds.npy")
  focal = focal_full * w / w_full
  return NDCViews(np.stack(images), c2w[idx].astype(np.float32), float(focal), tuple(names))
