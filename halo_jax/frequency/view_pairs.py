"""Pairs of nearby views for the frequency criterion, one kind per scene kind.

A pair is a base view and the same camera moved a small step along a path
natural to the scene kind:

  orbit       360-degree scenes: a camera on the training cameras' sphere, at
              a random azimuth and an elevation between the lowest and
              highest training camera, looking at the origin; it moves along
              its orbit about the scene's up (z) axis
  orbit_time  dynamic 360-degree scenes: the same, both views at one time
              drawn from the training frames' times
  spiral      forward-facing scenes: a pose on NeRF's spiral about the mean
              training pose (camera_paths.spiral_at); it moves along the spiral.
              Rendered with NDC rays, as the scene is trained
  uv          light fields: a random (u, v) inside the training cameras' box
              on the camera plane; it moves along u

The step is set in image terms, so that "nearby" means the same thing for
every kind: each pair's step is chosen so that the median displacement of the
base view's surface (the field's own depth, pixels with opacity > 0.5) is
`shift_px` pixels in a view whose short side is `size` pixels. Displacement is
linear in the step for light fields and nearly so for the small steps used
elsewhere: a probe step gives the scale and three rescalings correct it
(projections only; each pair is rendered twice). The same displacement field
resamples b onto a (warp_onto), so that a criterion can compare only what the
camera move does not explain.
"""
import dataclasses
from typing import Callable

import numpy as np

from halo_jax import camera, camera_paths, evaluate, lightfield
from halo_jax.datasets.base import Views
from halo_jax.datasets.llff import NDCViews
from halo_jax.datasets.stanford_lf import LightFieldViews
from halo_jax.registry import Registry

NDC_NEAR = 1.0   # the near plane NDCViews.rays uses


def criterion_size(height: int, width: int, size: int):
  """(h, w, k): the view size whose short side is `size` pixels, and the
  scale k from (height, width)."""
  k = size / min(height, width)
  return max(1, int(round(height * k))), max(1, int(round(width * k))), k


@dataclasses.dataclass(frozen=True)
class PairKind:
  """How one scene kind makes pairs.

  base(dataset, num, size, rng) -> Views at the criterion size
  move(views, steps [N]) -> the same Views moved by `steps` (kind's units)
  flow(views_a, views_b, render_a, dataset) -> [N, h, w, 2] where each pixel
    of a (its surface, by a's depth) lands in b, in b's pixel coordinates
  probe: the step whose displacement is measured to scale the real step
  max_step: the largest step used (an empty render has no displacement)
  """
  base: Callable
  move: Callable
  flow: Callable
  probe: float
  max_step: float
  unit: str


PAIR_KINDS: Registry[PairKind] = Registry("pair kind")


def _blank(n, h, w):
  return np.zeros((n, h, w, 3), np.float32)


def _names(n):
  return tuple(f"pair{i:03d}" for i in range(n))


# ---------------------------------------------------------------- 3D cameras


def project(c2w, focal, height, width, points):
  """Pixel coordinates (x right, y down, pixel centres at i + 0.5) of world
  `points` [N, ..., 3] in cameras c2w [N, 4, 4]: [N, ..., 2]; points behind
  a camera are NaN."""
  c2w = np.asarray(c2w, np.float64)
  rot, centre = c2w[:, :3, :3], c2w[:, :3, 3]
  shape = points.shape
  p = points.reshape(shape[0], -1, 3) - centre[:, None]
  cam = np.einsum("npk,nkj->npj", p, rot)           # (X - c) R = R^T (X - c)
  z = -cam[..., 2]
  z = np.where(z > 1e-9, z, np.nan)
  px = focal * cam[..., 0] / z + 0.5 * width
  py = -focal * cam[..., 1] / z + 0.5 * height
  return np.stack([px, py], -1).reshape(*shape[:-1], 2)


def world_points(views, render, ndc: bool):
  """Surface points [N, H, W, 3] in world space from a render's depth."""
  o, d = camera_rays(views)
  depth = np.asarray(render["depth"])[..., None]
  if not ndc:
    return o + depth * d
  o_n, d_n = views.rays()
  p = o_n + depth * d_n                              # NDC points
  ax, ay = -2.0 * views.focal / views.width, -2.0 * views.focal / views.height
  zp = np.minimum(p[..., 2], 1.0 - 1e-4)             # NDC z -> 1 is infinitely far
  z = 2.0 * NDC_NEAR / (zp - 1.0)
  return np.stack([p[..., 0] * z / ax, p[..., 1] * z / ay, z], -1)


def camera_rays(views):
  """World-space pixel rays of `views` (NDCViews too): origins, unit dirs."""
  return Views.rays(views)


def pixel_centres(n, h, w):
  """[n, h, w, 2] (x, y) pixel centres."""
  i, j = np.meshgrid(np.arange(w) + 0.5, np.arange(h) + 0.5, indexing="xy")
  return np.broadcast_to(np.stack([i, j], -1), (n, h, w, 2))


def _flow_3d(ndc):
  def flow(a, b, render_a, dataset):
    del dataset
    pts = world_points(a, render_a, ndc)
    return project(b.c2w, b.focal, b.height, b.width, pts)
  return flow


def median_shift(a, landed, render_a):
  """[N] median displacement |landed - pixel centre| over a's pixels with
  opacity > 0.5 (all pixels where none is)."""
  d = np.linalg.norm(landed - pixel_centres(len(landed), a.height, a.width), axis=-1)
  out = []
  for di, ai in zip(d, np.asarray(render_a["acc"])):
    seen = np.isfinite(di) & (ai > 0.5)
    if not seen.any():
      seen = np.isfinite(di)
    out.append(float(np.median(di[seen])) if seen.any() else 0.0)
  return np.asarray(out)


def _sized(views, size):
  h, w, k = criterion_size(views.height, views.width, size)
  return h, w, float(getattr(views, "focal", 0.0)) * w / views.width


def _orbit_base(dataset, num, size, rng):
  pos = np.asarray(dataset.train.c2w)[:, :3, 3].astype(np.float64)
  dist = np.linalg.norm(pos, axis=-1)
  elev = np.degrees(np.arcsin(np.clip(pos[:, 2] / dist, -1, 1)))
  az = rng.uniform(0.0, 360.0, num)
  el = rng.uniform(elev.min(), elev.max(), num)
  c2w = np.stack([camera.spherical_camera(dist.mean(), a, e) for a, e in zip(az, el)])
  h, w, focal = _sized(dataset.train, size)
  times = None
  if dataset.dynamic:
    times = rng.choice(np.asarray(dataset.train.times, np.float32), num)
  return Views(_blank(num, h, w), c2w.astype(np.float32), focal, _names(num),
               None if times is None else times.astype(np.float32))


def _orbit_move(views, steps):
  """Rotates each camera by steps[i] degrees about the world z axis."""
  out = []
  for c, s in zip(views.c2w, np.asarray(steps, np.float64)):
    a = np.deg2rad(s)
    rz = np.array([[np.cos(a), -np.sin(a), 0, 0], [np.sin(a), np.cos(a), 0, 0],
                   [0, 0, 1, 0], [0, 0, 0, 1]])
    out.append(rz @ np.asarray(c, np.float64))
  return dataclasses.replace(views, c2w=np.stack(out).astype(np.float32))


for _name in ("orbit", "orbit_time"):
  PAIR_KINDS.register(_name, PairKind(_orbit_base, _orbit_move, _flow_3d(False),
                                      probe=0.5, max_step=30.0, unit="degrees of azimuth"))


@dataclasses.dataclass(frozen=True)
class _SpiralViews(NDCViews):
  """NDC views that remember their phase on the spiral (to move along it)."""
  phases: np.ndarray = None
  spiral_c2w: np.ndarray = None
  bounds: np.ndarray = None


def _spiral_base(dataset, num, size, rng):
  bounds = dataset.depth_bounds
  if bounds is None:
    raise ValueError("spiral pairs need the scene's depth bounds (Dataset.depth_bounds)")
  phases = rng.uniform(0.0, 4 * np.pi, num)          # two turns, as the spiral video
  train_c2w = np.asarray(dataset.train.c2w)
  h, w, focal = _sized(dataset.train, size)
  return _SpiralViews(_blank(num, h, w), camera_paths.spiral_at(train_c2w, bounds, phases),
                      focal, _names(num), None, phases, train_c2w, np.asarray(bounds))


def _spiral_move(views, steps):
  phases = views.phases + np.asarray(steps, np.float64)
  return dataclasses.replace(views, phases=phases, c2w=camera_paths.spiral_at(
      views.spiral_c2w, views.bounds, phases))


PAIR_KINDS.register("spiral", PairKind(_spiral_base, _spiral_move, _flow_3d(True),
                                       probe=0.02, max_step=1.0, unit="radians along the spiral"))


# ---------------------------------------------------------------- light fields


def _uv_base(dataset, num, size, rng):
  uv = np.asarray(dataset.train.uv, np.float64)
  pts = rng.uniform(uv.min(0), uv.max(0), (num, 2))
  h, w, _ = _sized(dataset.train, size)
  return LightFieldViews(_blank(num, h, w), pts.astype(np.float32), _names(num))


def _uv_move(views, steps):
  uv = np.array(views.uv, np.float64)
  uv[:, 0] += np.asarray(steps, np.float64)
  return dataclasses.replace(views, uv=uv.astype(np.float32))


def _uv_flow(a, b, render_a, dataset):
  """A ray's point at EPI angle theta moves cot(theta) in s per unit of u;
  s spans the image's width (2 units over W pixels). The sign follows the
  two-plane rays: the point s' = s + u cot(theta) stays put, so s moves by
  -du cot(theta)."""
  theta = lightfield.theta_of_tau(np.asarray(render_a["depth"]), dataset.near, dataset.far)
  du = np.asarray(b.uv)[:, 0] - np.asarray(a.uv)[:, 0]
  landed = np.array(pixel_centres(len(du), a.height, a.width))
  landed[..., 0] -= du[:, None, None] / np.tan(theta) * a.width / 2.0
  return landed


PAIR_KINDS.register("uv", PairKind(_uv_base, _uv_move, _uv_flow, probe=0.01, max_step=0.5,
                                   unit="camera-plane units along u"))


# ---------------------------------------------------------------- the pairs


def warp_onto(rgb_a, rgb_b, landed, acc_a):
  """b's render resampled where a's surface landed in b: [N, h, w, 3].

  Bilinear at `landed` (b's pixel coordinates) where a's opacity is > 0.5
  and the point lands inside b; b's own pixel where a sees empty space (the
  background is fixed in image space, and a floater there is what the
  criterion should see); a's pixel where the point leaves b's frame.
  """
  n, h, w, _ = rgb_b.shape
  x = landed[..., 0] - 0.5
  y = landed[..., 1] - 0.5
  inside = np.isfinite(x) & np.isfinite(y) & (x >= 0) & (x <= w - 1) & (y >= 0) & (y <= h - 1)
  x = np.clip(np.nan_to_num(x), 0, w - 1)
  y = np.clip(np.nan_to_num(y), 0, h - 1)
  x0, y0 = np.floor(x).astype(int), np.floor(y).astype(int)
  x1, y1 = np.minimum(x0 + 1, w - 1), np.minimum(y0 + 1, h - 1)
  fx, fy = (x - x0)[..., None], (y - y0)[..., None]
  idx = np.arange(n)[:, None, None]
  sample = ((1 - fx) * (1 - fy) * rgb_b[idx, y0, x0] + fx * (1 - fy) * rgb_b[idx, y0, x1]
            + (1 - fx) * fy * rgb_b[idx, y1, x0] + fx * fy * rgb_b[idx, y1, x1])
  surface = (acc_a > 0.5)[..., None]
  return np.where(surface, np.where(inside[..., None], sample, rgb_a), rgb_b).astype(np.float32)


def make(render, dataset, num: int, size: int, shift_px: float, seed: int, chunk: int) -> dict:
  """Renders `num` pairs whose median surface displacement is `shift_px`.

  render: fn(o, d[, t]) -> {'rgb', 'depth', 'acc'} (restore's renderer),
  `chunk` rays a call; the dataset's training views place the pairs; size:
  the criterion's short side. Returns {'a', 'b': [num, h, w, 3] renders;
  'b_warped': b resampled onto a by a's depth (warp_onto); 'steps': [num]
  (the kind's units); 'shift_px': [num] each pair's measured displacement;
  'kind', 'unit'}.
  """
  name = dataset.facts.pair_kind
  if not name:
    raise ValueError("this scene kind declares no view pairs (SceneFacts.pair_kind)")
  kind = PAIR_KINDS.get(name)
  rng = np.random.default_rng(seed)
  base = kind.base(dataset, num, size, rng)
  ra = evaluate.render_views(render, base, chunk)
  probe = kind.move(base, np.full(num, kind.probe))
  shift = lambda moved: median_shift(base, kind.flow(base, moved, ra, dataset), ra)
  per_probe = shift(probe) / kind.probe
  steps = np.where(per_probe > 1e-9, shift_px / np.maximum(per_probe, 1e-9), kind.max_step)
  steps = np.minimum(steps, kind.max_step)
  for _ in range(3):  # displacement is not quite linear along a curved path: rescale
    got = shift(kind.move(base, steps))
    steps = np.minimum(np.where(got > 1e-9, steps * shift_px / np.maximum(got, 1e-9), steps),
                       kind.max_step)
  moved = kind.move(base, steps)
  rb = evaluate.render_views(render, moved, chunk)
  landed = kind.flow(base, moved, ra, dataset)
  a, b = np.asarray(ra["rgb"]), np.asarray(rb["rgb"])
  return {"a": a, "b": b, "b_warped": warp_onto(a, b, landed, np.asarray(ra["acc"])),
          "steps": steps, "shift_px": median_shift(base, landed, ra), "kind": name,
          "unit": kind.unit}
