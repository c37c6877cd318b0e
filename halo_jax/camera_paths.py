"""Camera paths for videos, one kind per scene kind, as Views to render.

  orbit       360-degree scenes: the test cameras' mean radius and elevation
  orbit_time  dynamic scenes: the orbit with time running from 0 to 1
  time        dynamic scenes: the first test camera, time running from 0 to 1
  spiral      forward-facing scenes: NeRF's spiral about the mean pose, two turns
  uv          light fields: an ellipse on the camera plane through the
              training views' mean offset from their centre
A path may also be a file: .npy [N, 4, 4] (or [N, 3, 4]) camera-to-world
matrices (OpenGL axes, the scene's frame), .npy [N, 2] (u, v) for light
fields, or Blender-style JSON {"frames": [{"transform_matrix": ..., "time": t}]}.
"""
import json

import numpy as np

from halo_jax import camera
from halo_jax.datasets.base import DataError, Views
from halo_jax.datasets.llff import NDCViews, average_pose
from halo_jax.datasets.llff_planes import PlaneRayViews
from halo_jax.datasets.stanford_lf import LightFieldViews
from halo_jax.geometry import Geometry

def _blank(n, h, w):
  return np.zeros((n, h, w, 3), np.float32)


def _names(n):
  return tuple(f"{i:04d}" for i in range(n))


def orbit_for(views):
  """(radius, elevation in degrees): the mean of `views`' cameras."""
  pos = views.c2w[:, :3, 3]
  r = np.linalg.norm(pos, axis=-1)
  return float(r.mean()), float(np.rad2deg(np.arcsin(np.clip(pos[:, 2] / r, -1, 1))).mean())


def spiral(c2w, bounds, n: int, turns: float = 2.0, z_rate: float = 0.5):
  """NeRF's forward-facing spiral: [n, 4, 4] camera-to-worlds.

  c2w [N, 4, 4] recentred training cameras; bounds [N, 2] their near / far
  scene depths. The cameras circle the mean pose with the radii of the
  cameras' 90th-percentile offsets, looking at the depth whose disparity is
  the 1:3 blend of the near and 5x-far disparities."""
  phases = np.linspace(0.0, 2 * np.pi * turns, n, endpoint=False)
  return spiral_at(c2w, bounds, phases, z_rate)


def spiral_at(c2w, bounds, phases, z_rate: float = 0.5):
  """The spiral's cameras at `phases` [n] (radians along it): [n, 4, 4]."""
  mean = average_pose(c2w[:, :3, :4])
  up = c2w[:, :3, 1].sum(0)
  up = up / np.linalg.norm(up)
  near, far = 0.9 * bounds.min(), 5.0 * bounds.max()
  focus = 1.0 / (0.25 / near + 0.75 / far)
  radii = np.percentile(np.abs(c2w[:, :3, 3] - mean[:, 3]), 90, axis=0)
  target = mean[:, 3] - focus * mean[:, 2]
  out = []
  for theta in np.asarray(phases, np.float64):
    offset = np.array([np.cos(theta), -np.sin(theta), -np.sin(theta * z_rate)]) * radii
    centre = mean[:, 3] + mean[:, :3] @ offset
    z = centre - target
    z /= np.linalg.norm(z)
    x = np.cross(up, z)
    x /= np.linalg.norm(x)
    pose = np.eye(4)
    pose[:3, :4] = np.stack([x, np.cross(z, x), z, centre], 1)
    out.append(pose)
  return np.stack(out).astype(np.float32)


def uv_ellipse(uv, n: int):
  """[n, 2] points on the ellipse through the mean |offset| of `uv` [N, 2]."""
  centre = uv.mean(0)
  radii = np.abs(uv - centre).mean(0)
  a = np.linspace(0.0, 2 * np.pi, n, endpoint=False)
  return (centre + radii * np.stack([np.cos(a), np.sin(a)], -1)).astype(np.float32)


def _read_file(path, geometry):
  """(c2w [N, 4, 4] or uv [N, 2], times [N] or None) from a path file."""
  if path.endswith(".json"):
    try:
      with open(path) as f:
        frames = json.load(f)["frames"]
      c2w = np.array([fr["transform_matrix"] for fr in frames], np.float32)
      times = [fr.get("time") for fr in frames]
    except (OSError, ValueError, KeyError, TypeError) as e:
      raise DataError(f"{path}: not a camera path ({e}); expected "
                      '{"frames": [{"transform_matrix": 4x4, "time": t}, ...]}') from e
    times = None if any(t is None for t in times) else np.array(times, np.float32)
  else:
    try:
      c2w, times = np.load(path).astype(np.float32), None
    except (OSError, ValueError) as e:
      raise DataError(f"{path}: cannot read as .npy ({e})") from e
  want = "[N, 2] (u, v)" if geometry == Geometry.TWO_PLANE else "[N, 4, 4] or [N, 3, 4]"
  ok = (c2w.ndim == 2 and c2w.shape[1] == 2) if geometry == Geometry.TWO_PLANE else (
      c2w.ndim == 3 and c2w.shape[1:] in ((4, 4), (3, 4)))
  if not ok or not np.all(np.isfinite(c2w)) or len(c2w) == 0:
    raise DataError(f"{path}: shape {c2w.shape}; a camera path here is {want}, finite")
  if c2w.ndim == 3 and c2w.shape[1] == 3:
    c2w = np.concatenate([c2w, np.broadcast_to([[[0, 0, 0, 1]]], (len(c2w), 1, 4))], 1)
  return c2w.astype(np.float32), times


def views_for(path: str, dataset, n: int, downscale: int = 1):
  """The Views of path `path` (one of dataset.facts.path_kinds, or a file) for `dataset`, at
  the test views' size divided by `downscale` (the field of view kept)."""
  geo, test = dataset.geometry, dataset.test
  h, w = test.height // downscale, test.width // downscale
  focal = getattr(test, "focal", 0.0) * w / test.width
  ramp = np.linspace(0.0, 1.0, n, dtype=np.float32)
  kinds = dataset.facts.path_kinds
  if path not in kinds and not path.endswith((".npy", ".json")):
    raise DataError(f"--path={path!r}: this scene ({geo.value} rays"
                    f"{', dynamic' if dataset.dynamic else ''}) takes one of "
                    f"{list(kinds)} or a .npy / .json file")
  slab = getattr(dataset.train, "slab", None)  # two planes placed in a scene (llff_planes)
  if geo == Geometry.TWO_PLANE and slab is None:
    uv = uv_ellipse(dataset.train.uv, n) if path == "uv" else _read_file(path, geo)[0]
    return LightFieldViews(_blank(len(uv), h, w), uv, _names(len(uv)))
  if slab is not None:
    geo = Geometry.NDC   # its cameras move as a forward-facing scene's
  times = None
  if path in ("orbit", "orbit_time"):
    radius, elevation = orbit_for(test)
    c2w = camera.orbit_path(radius, n, elevation)
    times = ramp if path == "orbit_time" else None
  elif path == "time":
    c2w, times = np.repeat(test.c2w[:1], n, 0), ramp
  elif path == "spiral":
    c2w = spiral(dataset.train.c2w, dataset.depth_bounds, n)
  else:
    c2w, times = _read_file(path, geo)
  if dataset.dynamic and times is None:  # a static path through a dynamic scene: t = 0
    times = np.zeros(len(c2w), np.float32)
  views = (_blank(len(c2w), h, w), np.asarray(c2w, np.float32), focal, _names(len(c2w)),
           None if times is None else np.asarray(times, np.float32))
  if slab is not None:
    return PlaneRayViews(*views, slab=slab)
  return (NDCViews if geo == Geometry.NDC else Views)(*views)
