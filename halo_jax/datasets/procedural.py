"""A built-in 360-degree scene, ray-cast analytically and written in the Blender layout.

Two spheres on a slab, with periodic textures (sinusoidal stripes, a checker),
lit by one directional light; colour is view-independent. Ground truth comes
from exact ray/sphere and ray/box intersections, so no network is involved and
the scene needs no download. Cameras lie on a sphere of radius 4.03 as in the
Blender scenes (train: random on the upper hemisphere; test: an orbit at 30
degrees elevation).
"""
import json
import os

import imageio.v3 as iio
import numpy as np

from halo_jax import camera

RADIUS = 4.03
CAMERA_ANGLE_X = 0.6911112070083618  # the lego scene's field of view
_LIGHT = np.array([0.4, -0.5, 0.77]) / np.linalg.norm([0.4, -0.5, 0.77])
_SPHERES = (  # centre, radius, texture id
    (np.array([0.0, 0.0, 0.1]), 0.75, 0),
    (np.array([0.85, -0.75, -0.25]), 0.4, 1),
)
_BOX = (np.array([-1.3, -1.3, -0.75]), np.array([1.3, 1.3, -0.6]))


def _hit_sphere(o, d, centre, r):
  oc = o - centre
  b = (oc * d).sum(-1)
  disc = b ** 2 - ((oc ** 2).sum(-1) - r ** 2)
  t = -b - np.sqrt(np.maximum(disc, 0.0))
  return np.where((disc > 0) & (t > 0), t, np.inf)


def _hit_box(o, d, lo, hi):
  with np.errstate(divide="ignore", invalid="ignore"):
    t0, t1 = (lo - o) / d, (hi - o) / d
  tmin = np.nanmax(np.minimum(t0, t1), -1)
  tmax = np.nanmin(np.maximum(t0, t1), -1)
  return np.where((tmax >= tmin) & (tmin > 0), tmin, np.inf)


def _box_normal(p, lo, hi):
  centre, half = 0.5 * (lo + hi), 0.5 * (hi - lo)
  q = (p - centre) / half
  axis = np.argmax(np.abs(q), -1)
  n = np.zeros_like(p)
  np.put_along_axis(n, axis[..., None], np.take_along_axis(np.sign(q), axis[..., None], -1), -1)
  return n


def render_rays(o, d):
  """Exact colour and alpha of rays o, d [..., 3] -> rgba [..., 4], depth [...]."""
  hits = [_hit_sphere(o, d, c, r) for c, r, _ in _SPHERES] + [_hit_box(o, d, *_BOX)]
  t = np.stack(hits, -1)
  which = np.argmin(t, -1)
  t_hit = np.min(t, -1)
  hit = np.isfinite(t_hit)
  p = o + np.where(hit, t_hit, 0.0)[..., None] * d
  albedo = np.zeros_like(p)
  normal = np.zeros_like(p)
  for k, (c, r, tex) in enumerate(_SPHERES):
    m = which == k
    n = (p - c) / r
    lon, lat = np.arctan2(n[..., 1], n[..., 0]), np.arcsin(np.clip(n[..., 2], -1, 1))
    if tex == 0:  # smooth stripes in longitude, modulated in latitude
      s = 0.5 + 0.5 * np.sin(8 * lon) * np.cos(3 * lat)
      col = np.stack([0.9 * s + 0.1, 0.3 + 0.4 * (1 - s), 0.2 + 0.6 * (1 - s)], -1)
    else:  # fine latitude bands
      s = (np.sin(14 * lat) > 0).astype(np.float64)
      col = np.stack([0.2 + 0.6 * s, 0.7 - 0.4 * s, 0.3 + 0.0 * s], -1)
    albedo = np.where(m[..., None], col, albedo)
    normal = np.where(m[..., None], n, normal)
  m = which == len(_SPHERES)
  check = ((np.floor(p[..., 0] / 0.325) + np.floor(p[..., 1] / 0.325)) % 2)[..., None]
  albedo = np.where(m[..., None], 0.25 + 0.6 * check * np.array([0.9, 0.85, 0.6]), albedo)
  normal = np.where(m[..., None], _box_normal(p, *_BOX), normal)
  shade = 0.35 + 0.65 * np.clip((normal * _LIGHT).sum(-1, keepdims=True), 0.0, 1.0)
  rgb = np.clip(albedo * shade, 0.0, 1.0)
  rgba = np.concatenate([np.where(hit[..., None], rgb, 0.0), hit[..., None].astype(float)], -1)
  return rgba, np.where(hit, t_hit, 0.0)


def generate(root: str, size: int = 100, num_train: int = 100, num_test: int = 200,
             seed: int = 0) -> str:
  """Writes the scene to `root` (skipped if already complete); returns root."""
  done = os.path.join(root, ".complete")
  if os.path.exists(done):
    return root
  rng = np.random.default_rng(seed)
  focal = 0.5 * size / np.tan(0.5 * CAMERA_ANGLE_X)
  train_poses = [camera.spherical_camera(RADIUS, rng.uniform(0, 360),
                                         np.rad2deg(np.arcsin(rng.uniform(0.05, 0.95))))
                 for _ in range(num_train)]
  test_poses = [camera.spherical_camera(RADIUS, az, 30.0)
                for az in np.linspace(-180, 180, num_test, endpoint=False)]
  for split, poses in (("train", train_poses), ("test", test_poses)):
    os.makedirs(os.path.join(root, split), exist_ok=True)
    frames = []
    for i, c2w in enumerate(poses):
      o, d = camera.pixel_rays(c2w, size, size, focal)
      rgba, _ = render_rays(o.astype(np.float64), d.astype(np.float64))
      iio.imwrite(os.path.join(root, split, f"r_{i}.png"),
                  np.round(rgba * 255).astype(np.uint8))
      frames.append({"file_path": f"./{split}/r_{i}", "transform_matrix": c2w.tolist()})
    with open(os.path.join(root, f"transforms_{split}.json"), "w") as f:
      json.dump({"camera_angle_x": CAMERA_ANGLE_X, "frames": frames}, f, indent=1)
  open(done, "w").close()
  return root
