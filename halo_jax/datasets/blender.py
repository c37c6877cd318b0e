"""NeRF-synthetic (Blender) loader: transforms_<split>.json + RGBA PNGs."""
import json
import os
from typing import Optional, Sequence

import imageio.v3 as iio
import numpy as np

from halo_jax.datasets.base import DataError, Views


def _read_transforms(root: str, split: str):
  path = os.path.join(root, f"transforms_{split}.json")
  if not os.path.exists(path):
    raise DataError(f"{path}: file not found (data.root={root!r}, split {split!r})")
  try:
    with open(path) as f:
      meta = json.load(f)
  except json.JSONDecodeError as e:
    raise DataError(f"{path}: malformed JSON ({e})") from e
  if not isinstance(meta, dict):
    raise DataError(f"{path}: expected a JSON object with 'camera_angle_x' and 'frames'")
  if "camera_angle_x" not in meta:
    raise DataError(f"{path}: missing field 'camera_angle_x'")
  angle = meta["camera_angle_x"]
  if (isinstance(angle, bool) or not isinstance(angle, (int, float))
      or not 0 < angle < np.pi):
    raise DataError(f"{path}: field 'camera_angle_x' must be a number in (0, pi) radians, "
                    f"got {angle!r}")
  frames = meta.get("frames")
  if not isinstance(frames, list) or not frames:
    raise DataError(f"{path}: missing or empty field 'frames'")
  for i, fr in enumerate(frames):
    for key in ("file_path", "transform_matrix"):
      if key not in fr:
        raise DataError(f"{path}: frames[{i}] has no field {key!r}")
  return path, meta


def view_name(file_path: str) -> str:
  """'./train/r_2' or 'train/r_2.png' -> 'r_2'."""
  return os.path.splitext(os.path.basename(file_path))[0]


def _downscale(image: np.ndarray, factor: int, path: str) -> np.ndarray:
  if factor == 1:
    return image
  h, w = image.shape[:2]
  if h % factor or w % factor:
    raise DataError(f"{path}: size {w}x{h} is not divisible by data.factor={factor}")
  # Box filter = area resampling for integer factors.
  return image.reshape(h // factor, factor, w // factor, factor, -1).mean((1, 3))


def load_image(path: str, factor: int, white_background: bool,
               crop_to_factor: bool = False) -> np.ndarray:
  """Reads an RGB(A) image as float32 [H, W, 3], downscaled and composited.
  crop_to_factor: drop the last rows and columns that `factor` does not
  divide (moves the principal point by under half a downscaled pixel)."""
  if not os.path.exists(path):
    raise DataError(f"{path}: image file not found")
  try:
    img = iio.imread(path)
  except Exception as e:  # imageio raises several types for corrupt files
    raise DataError(f"{path}: cannot read image ({e})") from e
  img = np.asarray(img, np.float32) / (65535.0 if img.dtype == np.uint16 else 255.0)
  if img.ndim == 2:
    img = np.repeat(img[..., None], 3, -1)
  if crop_to_factor:
    img = img[:img.shape[0] - img.shape[0] % factor, :img.shape[1] - img.shape[1] % factor]
  img = _downscale(img, factor, path)
  if img.shape[-1] == 4:
    rgb, alpha = img[..., :3], img[..., 3:]
    # Downscaled RGBA is averaged straight, then composited, as in NeRF's loader.
    img = rgb * alpha + (1.0 - alpha) if white_background else rgb * alpha
  return img[..., :3].astype(np.float32)


def load_views(root: str, split: str, factor: int = 1,
               names: Optional[Sequence[str]] = None,
               white_background: bool = True) -> Views:
  """Loads split ('train', 'test', 'val') of the scene folder root (its
  transforms_<split>.json), only the views `names` in that order (e.g.
  ['r_2', 'r_16']; None: all), downscaled by the integer factor (8: 100x100
  from 800x800), RGBA composited onto white with white_background."""
  path, meta = _read_transforms(root, split)
  frames = {view_name(fr["file_path"]): fr for fr in meta["frames"]}
  if names is None:
    names = list(frames)
  missing = [n for n in names if n not in frames]
  if missing:
    raise DataError(f"{path}: views {missing} named in the config are not in 'frames'")
  images, poses, times = [], [], []
  for n in names:
    fr = frames[n]
    fp = fr["file_path"]
    img_path = os.path.normpath(os.path.join(root, fp if os.path.splitext(fp)[1] else fp + ".png"))
    img = load_image(img_path, factor, white_background)
    if images and img.shape != images[0].shape:
      (h, w), (h0, w0) = img.shape[:2], images[0].shape[:2]
      raise DataError(f"{img_path}: size {w * factor}x{h * factor} differs from "
                      f"{w0 * factor}x{h0 * factor} of the other views")
    images.append(img)
    poses.append(rigid_pose(fr["transform_matrix"], path, n))
    times.append(_frame_time(fr, path, n))
  width = images[0].shape[1]
  focal = 0.5 * width / np.tan(0.5 * float(meta["camera_angle_x"]))
  has_time = [t is not None for t in times]
  if any(has_time) and not all(has_time):
    raise DataError(f"{path}: field 'time' is on some frames but not on "
                    f"{names[has_time.index(False)]}")
  times = np.asarray(times, np.float32) if all(has_time) else None
  return Views(np.stack(images), np.stack(poses).astype(np.float32), float(focal), tuple(names),
               times)


def rigid_pose(matrix, path, name) -> np.ndarray:
  """A frame's 'transform_matrix' as a rigid camera-to-world [4, 4]; DataError
  naming the file and the frame otherwise."""
  try:
    pose = np.asarray(matrix, np.float64)
  except (TypeError, ValueError):
    pose = np.full((0,), np.nan)
  if pose.shape != (4, 4) or not np.all(np.isfinite(pose)):
    raise DataError(f"{path}: 'transform_matrix' of {name} is not a finite 4x4 matrix")
  rot = pose[:3, :3]
  if not np.allclose(rot @ rot.T, np.eye(3), atol=1e-3):
    raise DataError(f"{path}: 'transform_matrix' of {name} is not rigid (R R^T != I)")
  if np.linalg.det(rot) < 0:
    raise DataError(f"{path}: 'transform_matrix' of {name} is not rigid (a reflection, det R < 0)")
  if not np.allclose(pose[3], [0, 0, 0, 1]):
    raise DataError(f"{path}: 'transform_matrix' of {name} has last row {pose[3].tolist()}, "
                    "not [0, 0, 0, 1]")
  return pose


def _frame_time(frame, path, name):
  """A D-NeRF frame's 'time' in [0, 1], or None when the frame has none."""
  if "time" not in frame:
    return None
  t = frame["time"]
  if isinstance(t, bool) or not isinstance(t, (int, float)) or not 0.0 <= t <= 1.0:
    raise DataError(f"{path}: field 'time' of {name} must be a number in [0, 1], got {t!r}")
  return float(t)
