"""LLFF scenes as two-plane light fields, as the authors' code runs them
(their AugLLFFDataset with EPINeLFRays; docs/differences.md).

World rays (no NDC) are cut by two planes normal to the central camera's
viewing axis: the (u, v) plane through that camera, the (s, t) plane at the
scene's far bound in front of it. A ray is then (u, v, s, t), each pair the
crossing point's coordinates along the central camera's right and up axes, in
scene units. Points on a ray are placed by their distance d from the (u, v)
plane, in [near, far] = [0.9 x the nearest bound, the farthest bound] (their
no-NDC LLFF bounds), as lightfield.depth_points aligns them.

The central camera is the one nearest the mean camera centre (NeRF's i_test
for LLFF), whichever views train.
"""
import dataclasses

import numpy as np

from halo_jax.datasets import llff
from halo_jax.datasets.base import DataError, Views

NEAR_FACTOR = 0.9   # their no-NDC near: 0.9 x the nearest bound


@dataclasses.dataclass(frozen=True)
class LightSlab:
  """The two planes: the (u, v) plane through `origin` with normal `axis`
  (the central camera's viewing direction), the (s, t) plane at distance
  `far` along it; in-plane coordinates along `right` and `up` (each [3])."""
  origin: np.ndarray
  right: np.ndarray
  up: np.ndarray
  axis: np.ndarray
  far: float

  def coords(self, origins, directions):
    """(uv, st), each [..., 2], of world rays origins, directions [..., 3]."""
    o = np.asarray(origins, np.float64)
    d = np.asarray(directions, np.float64)
    along = d @ self.axis
    if np.any(np.abs(along) < 1e-6):
      raise DataError("a ray runs parallel to the light slab's planes")
    out = []
    for depth in (0.0, self.far):
      t = (depth - (o - self.origin) @ self.axis) / along
      x = o + t[..., None] * d - self.origin
      out.append(np.stack([x @ self.right, x @ self.up], -1).astype(np.float32))
    return out[0], out[1]


def central_index(c2w) -> int:
  """The camera nearest the mean camera centre."""
  centres = c2w[:, :3, 3]
  return int(np.argmin(np.linalg.norm(centres - centres.mean(0), axis=-1)))


def slab_of(root: str):
  """The scene's LightSlab and its depth range (near, far) from poses_bounds.npy."""
  c2w, _, _, bounds = llff.read_poses(root)
  near, far = NEAR_FACTOR * float(bounds.min()), float(bounds.max())
  if not 0 < near < far:
    raise DataError(f"{root}: depth bounds ({near}, {far}) do not make a range")
  c = c2w[central_index(c2w)].astype(np.float64)
  # OpenGL axes: the camera looks down -z
  slab = LightSlab(c[:3, 3], c[:3, 0], c[:3, 1], -c[:3, 2], far)
  return slab, near, far


@dataclasses.dataclass(frozen=True)
class PlaneRayViews(Views):
  """Posed views whose rays() are two-plane rays (u, v, 0), (s, t, 1) through `slab`."""
  slab: LightSlab = None

  def rays(self):
    o, d = super().rays()
    uv, st = self.slab.coords(o, d)
    zeros = np.zeros(uv.shape[:-1] + (1,), np.float32)
    return (np.concatenate([uv, zeros], -1), np.concatenate([st, zeros + 1.0], -1))


def load_views(root: str, factor: int, names, slab: LightSlab) -> PlaneRayViews:
  """The named views of an LLFF scene, their rays through `slab`."""
  v = llff.load_views(root, factor, names)
  return PlaneRayViews(v.images, v.c2w, v.focal, v.names, slab=slab)
