"""Your own capture: a COLMAP model, nerfstudio's transforms.json, or a folder
of photos that structure-from-motion (pycolmap, on the CPU) turns into one.

data.root is read in this order:
  transforms.json          nerfstudio: per-frame `transform_matrix` (OpenGL
                           camera-to-world), intrinsics shared or per frame
  sparse/0 or sparse/      a COLMAP model (cameras, images, points3D; binary
                           or text), read by pycolmap, images in images/
  images/ (or the photos   no model yet: features, exhaustive matching and
  in data.root itself)     incremental mapping by pycolmap, cached in sparse/

Views have one centred pinhole camera (COLMAP's distorted cameras are
undistorted first, by pycolmap). A 360-degree capture (data.kind='capture')
is recentred, turned z-up and scaled to the Blender scenes' radius; a
forward-facing one ('capture_ff') gets LLFF's depth bounds and NDC rays.
data.train_views='farthest:K' picks K cameras by farthest point sampling.
docs/capture.md gives each step and what is refused.
"""
import dataclasses
import os

import numpy as np
import tqdm

from halo_jax.datasets import blender, colmap, llff, posed_photos
from halo_jax.datasets.posed_photos import Capture
from halo_jax.datasets.base import (DataError, Dataset, Similarity, Views, camera_radius,
                                    view_names)
from halo_jax.geometry import Geometry

RADIUS = 4.03                 # camera distance of 360-degree captures, as the Blender scenes
FORWARD_DEGREES = 45.0        # forward-facing: every camera axis within this of the mean one


def read(root: str) -> Capture:
  """The capture in `root`, by the first source present (module docstring)."""
  if not root or not os.path.isdir(root):
    raise DataError(f"data.root={root!r}: not a folder; pass --config.data.root=DIR (photos, a "
                    "COLMAP model or transforms.json)")
  if os.path.exists(os.path.join(root, "transforms.json")):
    return posed_photos.read_transforms(root)
  return colmap.read_colmap(root, colmap.model_folder(root) or colmap.run_sfm(root))


def farthest_cameras(centres, k: int):
  """Indices of k cameras by farthest point sampling on centres [N, 3],
  starting from camera 0 (deterministic)."""
  if not 0 < k <= len(centres):
    raise DataError(f"data.train_views='farthest:{k}': the capture has {len(centres)} cameras")
  chosen = [0]
  dist = np.linalg.norm(centres - centres[0], axis=-1)
  while len(chosen) < k:
    nxt = int(np.argmax(dist))
    chosen.append(nxt)
    dist = np.minimum(dist, np.linalg.norm(centres - centres[nxt], axis=-1))
  return sorted(chosen)


def forward_facing(c2w) -> bool:
  """Whether every camera looks within FORWARD_DEGREES of the mean direction."""
  look = -c2w[:, :3, 2]
  mean = look.mean(0) / max(np.linalg.norm(look.mean(0)), 1e-12)
  return bool(np.all(look @ mean > np.cos(np.deg2rad(FORWARD_DEGREES))))


def point_depths(c2w, points):
  """Depth of every point in front of every camera: a list of N arrays."""
  out = []
  for m in c2w:
    z = -(points - m[:3, 3]) @ m[:3, 2]  # OpenGL: the camera looks down -z
    out.append(z[z > 0])
  return out


def _focus(c2w):
  """The point nearest every camera's viewing axis (least squares)."""
  look = -c2w[:, :3, 2]
  m = np.eye(3)[None] - look[:, :, None] * look[:, None, :]
  return np.linalg.solve(m.sum(0), (m @ c2w[:, :3, 3:4]).sum(0))[:, 0]


def _up_to_z(up):
  """A rotation [3, 3] that takes the unit vector `up` to +z."""
  z = up / np.linalg.norm(up)
  a = np.array([1.0, 0, 0]) if abs(z[0]) < 0.9 else np.array([0, 1.0, 0])
  x = np.cross(a, z)
  x /= np.linalg.norm(x)
  return np.stack([x, np.cross(z, x), z])


def sphere_frame(c2w) -> Similarity:
  """The similarity that takes a 360-degree capture with camera-to-world
  c2w [N, 4, 4] into the Blender scenes' frame: centred on the point its
  cameras look at, +z up, cameras at RADIUS on average."""
  focus = _focus(c2w)
  rot = _up_to_z(c2w[:, :3, 1].mean(0))
  scale = RADIUS / np.linalg.norm((c2w[:, :3, 3] - focus) @ rot.T, axis=-1).mean()
  return Similarity(rot, float(scale), -scale * rot @ focus)


def to_sphere(cap: Capture):
  """(c2w [N, 4, 4], points or None, near, far, frame) of a 360-degree
  capture in the Blender scenes' frame (sphere_frame)."""
  frame = sphere_frame(cap.c2w)
  c2w = frame.poses(cap.c2w)
  points = None if cap.points is None else frame.points(cap.points)
  depths = [] if points is None else [z for z in point_depths(c2w, points) if z.size]
  if depths:
    near = 0.9 * min(np.percentile(z, 1) for z in depths)
    far = 1.1 * max(np.percentile(z, 99) for z in depths)
  else:  # no sparse points: the sphere's inside, seen from its surface
    near, far = 0.1 * RADIUS, 2.0 * RADIUS
  return c2w, points, float(max(near, 1e-3)), float(far), frame


def forward_bounds(cap: Capture):
  """Per-camera near / far scene depth [N, 2] from the sparse points (LLFF's
  0.1 and 99.9 percentiles)."""
  if cap.points is None:
    raise DataError("a forward-facing capture needs sparse points for its depth bounds "
                    "(a COLMAP model, or transforms.json with ply_file_path)")
  depths = point_depths(cap.c2w, cap.points)
  if any(z.size == 0 for z in depths):
    bad = cap.names[[z.size == 0 for z in depths].index(True)]
    raise DataError(f"camera {bad} sees none of the sparse points")
  return np.array([[np.percentile(z, 0.1), np.percentile(z, 99.9)] for z in depths])


def split(cap: Capture, cfg):
  """(train indices, test indices) from data.train_views / data.test_views."""
  names = list(cap.names)
  spec = cfg.train_views
  if isinstance(spec, str) and spec.startswith("farthest:"):
    train = farthest_cameras(cap.c2w[:, :3, 3], int(spec.split(":")[1]))
  else:
    chosen = view_names(spec, names) or names
    _check_known(chosen, names, "data.train_views")
    train = [names.index(n) for n in chosen]
  rest = [n for i, n in enumerate(names) if i not in train]
  chosen = view_names(cfg.test_views, rest) or rest
  _check_known(chosen, names, "data.test_views")
  if not chosen:
    raise DataError(f"data.test_views={cfg.test_views!r}: no held-out cameras are left")
  return train, [names.index(n) for n in chosen]


def _check_known(chosen, names, field):
  missing = [n for n in chosen if n not in names]
  if missing:
    raise DataError(f"{field}: views {missing[:5]} are not registered cameras of the capture")


def _images(cap: Capture, idx, factor: int):
  images = [blender.load_image(cap.paths[i], factor, False, crop_to_factor=True) for i in
            tqdm.tqdm(idx, desc="photos", unit="image", leave=False)]
  h, w = images[0].shape[:2]
  for i, img in zip(idx, images):
    if img.shape[:2] != (h, w) or abs(w * factor - cap.width) > factor:
      raise DataError(f"{cap.paths[i]}: size {img.shape[1] * factor}x{img.shape[0] * factor}, "
                      f"the camera is {cap.width}x{cap.height}")
  return np.stack(images), cap.focal * w / cap.width


def _views(cap: Capture, cfg, cls):
  """(train, test) views of class `cls` (Views or NDCViews) of the split."""
  out = []
  for idx in split(cap, cfg):
    images, focal = _images(cap, idx, cfg.factor)
    out.append(cls(images, cap.c2w[idx].astype(np.float32), float(focal),
                   tuple(cap.names[i] for i in idx)))
  return out


def load_sphere(cfg, workdir="") -> Dataset:
  """data.kind='capture': a 360-degree capture with sphere rays."""
  del workdir
  cap = read(cfg.root)
  if forward_facing(cap.c2w):
    raise DataError(f"{cfg.root}: every camera looks within {FORWARD_DEGREES:g} degrees of one "
                    "direction, a forward-facing capture: use data.kind='capture_ff' "
                    "(configs/capture.py:<k>view_ff)")
  c2w, _, near, far, _ = to_sphere(cap)
  cap = dataclasses.replace(cap, c2w=c2w)
  train, test = _views(cap, cfg, Views)
  return Dataset(train, test, near, far, camera_radius(train.c2w), False, Geometry.SPHERE)


def load_forward(cfg, workdir="") -> Dataset:
  """data.kind='capture_ff': a forward-facing capture in NDC (LLFF's rays)."""
  del workdir
  cap = read(cfg.root)
  if not forward_facing(cap.c2w):
    raise DataError(f"{cfg.root}: the cameras look in directions more than "
                    f"{FORWARD_DEGREES:g} degrees apart, not a forward-facing capture: use "
                    "data.kind='capture' (configs/capture.py:<k>view)")
  c2w, bounds = llff.normalize_forward_facing(cap.c2w, forward_bounds(cap))
  cap = dataclasses.replace(cap, c2w=c2w)
  train, test = _views(cap, cfg, llff.NDCViews)
  return Dataset(train, test, 0.0, 1.0, 0.0, False, Geometry.NDC, depth_bounds=bounds)
