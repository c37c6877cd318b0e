"""Built-in 360-degree scenes, ray-cast analytically and written in the Blender layout.

Each scene is a few primitives (spheres, axis-aligned boxes, vertical tubes)
with periodic textures, lit by one directional light; colour is
view-independent. Ground truth comes from exact ray/primitive intersections,
so no network is involved and no download is needed. Cameras lie on a sphere
of radius 4.03 as in the Blender scenes. SCENES:

  spheres   two textured spheres on a checkered slab; training cameras random
            on the upper hemisphere, test cameras on a 30-degree orbit.
  textured  a sphere and two boxes covered in random-coloured cells, cameras
            all round: texture for structure-from-motion to match.
  lattice   what few views underconstrain: eight thin banded rods (radius
            0.035) and thin cross-bars around a small finely checkered core,
            in a large empty volume (the object fills a quarter of the
            frame's width); training cameras only on one half of the
            azimuths (x > 0), test cameras on the full orbit, so half of
            every test orbit looks at sides no training view saw.
  thin      stress: a plant (a thin stem, small leaves on a spiral, a small
            pot) covering about a tenth of each frame, on white.
  sparse    stress: two small objects far apart in a mostly empty volume
            (a few per cent of each frame).

Every scene also has a `val` split: cameras at random azimuths (all round,
whatever the training side) and elevations, none on the test orbit, for
choosing settings without the test views (data.test_split='val').
"""
import dataclasses
import json
import os
from typing import Callable, Tuple

import numpy as np

from halo_jax import camera, image_files

RADIUS = 4.03
CAMERA_ANGLE_X = 0.6911112070083618  # the lego scene's field of view
_LIGHT = np.array([0.4, -0.5, 0.77]) / np.linalg.norm([0.4, -0.5, 0.77])


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


def _hit_tube(o, d, cx, cy, r, z0, z1):
  """Entry point of a vertical cylinder's side, z0 <= z <= z1 (no caps: the
  tubes are thin enough that a ray through a cap is a fraction of a pixel)."""
  ox, oy = o[..., 0] - cx, o[..., 1] - cy
  a = d[..., 0] ** 2 + d[..., 1] ** 2
  b = ox * d[..., 0] + oy * d[..., 1]
  disc = b ** 2 - a * (ox ** 2 + oy ** 2 - r ** 2)
  with np.errstate(divide="ignore", invalid="ignore"):
    t = (-b - np.sqrt(np.maximum(disc, 0.0))) / a
  z = o[..., 2] + t * d[..., 2]
  ok = (disc > 0) & (a > 1e-12) & (t > 0) & (z >= z0) & (z <= z1)
  return np.where(ok, t, np.inf)


def _box_normal(p, lo, hi):
  centre, half = 0.5 * (lo + hi), 0.5 * (hi - lo)
  q = (p - centre) / half
  axis = np.argmax(np.abs(q), -1)
  n = np.zeros_like(p)
  np.put_along_axis(n, axis[..., None], np.take_along_axis(np.sign(q), axis[..., None], -1), -1)
  return n


@dataclasses.dataclass(frozen=True)
class Primitive:
  """hit(o, d) -> t [...] (inf on a miss); surface(p) -> (albedo, normal) [..., 3] each."""
  hit: Callable
  surface: Callable


def sphere(centre, r, texture) -> Primitive:
  """texture(lon, lat) -> albedo [..., 3]."""
  centre = np.asarray(centre, np.float64)

  def surface(p):
    n = (p - centre) / r
    lon, lat = np.arctan2(n[..., 1], n[..., 0]), np.arcsin(np.clip(n[..., 2], -1, 1))
    return texture(lon, lat), n
  return Primitive(lambda o, d: _hit_sphere(o, d, centre, r), surface)


def box(lo, hi, texture) -> Primitive:
  """texture(p) -> albedo [..., 3]."""
  lo, hi = np.asarray(lo, np.float64), np.asarray(hi, np.float64)
  return Primitive(lambda o, d: _hit_box(o, d, lo, hi),
                   lambda p: (texture(p), _box_normal(p, lo, hi)))


def tube(cx, cy, r, z0, z1, texture) -> Primitive:
  """texture(z) -> albedo [..., 3]."""
  def surface(p):
    n = np.stack([(p[..., 0] - cx) / r, (p[..., 1] - cy) / r, np.zeros(p.shape[:-1])], -1)
    return texture(p[..., 2]), n
  return Primitive(lambda o, d: _hit_tube(o, d, cx, cy, r, z0, z1), surface)


def _stripes_tex(lon, lat):  # smooth stripes in longitude, modulated in latitude
  s = 0.5 + 0.5 * np.sin(8 * lon) * np.cos(3 * lat)
  return np.stack([0.9 * s + 0.1, 0.3 + 0.4 * (1 - s), 0.2 + 0.6 * (1 - s)], -1)


def _bands_tex(lon, lat):  # fine latitude bands
  s = (np.sin(14 * lat) > 0).astype(np.float64)
  return np.stack([0.2 + 0.6 * s, 0.7 - 0.4 * s, 0.3 + 0.0 * s], -1)


def _slab_tex(p):
  check = ((np.floor(p[..., 0] / 0.325) + np.floor(p[..., 1] / 0.325)) % 2)[..., None]
  return 0.25 + 0.6 * check * np.array([0.9, 0.85, 0.6])


def _core_tex(lon, lat):  # a fine checker: 16 cells around, 10 from pole to pole
  s = ((np.floor(lon * 16 / (2 * np.pi)) + np.floor(lat * 10 / np.pi)) % 2)[..., None]
  return s * np.array([0.95, 0.8, 0.2]) + (1 - s) * np.array([0.15, 0.25, 0.7])


def _rod_tex(z):  # bands 0.1 high along each rod
  s = (np.sin(np.pi * z / 0.1) > 0).astype(np.float64)[..., None]
  return s * np.array([0.85, 0.2, 0.2]) + (1 - s) * np.array([0.9, 0.9, 0.85])


def _bar_tex(p):
  s = (np.sin(np.pi * (p[..., 0] + p[..., 1]) / 0.08) > 0).astype(np.float64)[..., None]
  return s * np.array([0.2, 0.6, 0.3]) + (1 - s) * np.array([0.95, 0.95, 0.9])


def _cells(p, size):
  """A colour per cube of side `size` that `p` [..., 3] falls in, random-looking
  (a hash of the cell's integer coordinates): texture that feature matching
  can tell apart everywhere."""
  cell = np.floor(p / size)
  h = np.sin(cell @ np.array([[12.9898, 4.1414, 7.31], [78.233, 2.71, 1.93], [37.719, 9.17, 5.3]]))
  return 0.15 + 0.8 * (h * 43758.5453 % 1.0)


def _textured():
  cells = lambda p: _cells(p, 0.08)
  return (sphere((0.0, 0.0, 0.2), 0.7, lambda lon, lat: _cells(
              np.stack([np.cos(lat) * np.cos(lon), np.cos(lat) * np.sin(lon), np.sin(lat)], -1),
              0.12)),
          box((0.55, -1.1, -0.75), (1.15, -0.5, 0.1), cells),
          box((-1.5, -1.5, -0.9), (1.5, 1.5, -0.75), cells))


def _lattice():
  rods = [tube(0.95 * np.cos(a), 0.95 * np.sin(a), 0.035, -0.9, 0.9, _rod_tex)
          for a in np.linspace(0, 2 * np.pi, 8, endpoint=False)]
  bars = [box((-0.95, -0.025, 0.9), (0.95, 0.025, 0.95), _bar_tex),
          box((-0.025, -0.95, -0.95), (0.025, 0.95, -0.9), _bar_tex)]
  return (sphere((0.0, 0.0, 0.0), 0.4, _core_tex), *rods, *bars)


def _leaf_tex(lon, lat):  # two greens in bands: texture on a thin object
  s = (np.sin(6 * lon + 9 * lat) > 0).astype(np.float64)[..., None]
  return s * np.array([0.2, 0.55, 0.2]) + (1 - s) * np.array([0.1, 0.35, 0.12])


def _stem_tex(z):
  s = (np.sin(np.pi * z / 0.15) > 0).astype(np.float64)[..., None]
  return s * np.array([0.45, 0.3, 0.15]) + (1 - s) * np.array([0.3, 0.2, 0.1])


def _thin():
  """A plant: a thin stem, small leaves on a spiral round it, a small pot."""
  leaves = [sphere((0.38 * np.cos(a), 0.38 * np.sin(a), z), 0.12, _leaf_tex)
            for a, z in zip(np.linspace(0, 5 * np.pi, 12), np.linspace(-0.5, 1.0, 12))]
  return (tube(0.0, 0.0, 0.04, -0.85, 1.1, _stem_tex), *leaves,
          box((-0.22, -0.22, -1.15), (0.22, 0.22, -0.85), _slab_tex))


def _sparse():
  """Mostly empty volume: two small objects far apart."""
  return (sphere((0.7, 0.5, 0.35), 0.28, _stripes_tex),
          box((-0.95, -0.75, -0.7), (-0.65, -0.45, -0.4), _slab_tex))


@dataclasses.dataclass(frozen=True)
class Scene:
  primitives: Tuple[Primitive, ...]
  train_azimuth: Tuple[float, float] = (0.0, 360.0)  # degrees, random within
  train_sin_elevation: Tuple[float, float] = (0.05, 0.95)


SCENES = {
    "spheres": Scene((sphere((0.0, 0.0, 0.1), 0.75, _stripes_tex),
                      sphere((0.85, -0.75, -0.25), 0.4, _bands_tex),
                      box((-1.3, -1.3, -0.75), (1.3, 1.3, -0.6), _slab_tex))),
    "lattice": Scene(_lattice(), train_azimuth=(-90.0, 90.0)),
    # dense random texture everywhere: what structure-from-motion needs to
    # recover its cameras (the capture loader's test)
    "textured": Scene(_textured()),
    # stress scenes (docs/validation.md): a thin object on white, about a tenth
    # of each frame; and a volume that is mostly empty
    "thin": Scene(_thin()),
    "sparse": Scene(_sparse()),
}


def render_rays(o, d, scene: str = "spheres"):
  """Exact colour and alpha of rays o, d [..., 3] -> rgba [..., 4], depth [...]."""
  prims = SCENES[scene].primitives
  t = np.stack([p.hit(o, d) for p in prims], -1)
  which = np.argmin(t, -1)
  t_hit = np.min(t, -1)
  hit = np.isfinite(t_hit)
  p = o + np.where(hit, t_hit, 0.0)[..., None] * d
  albedo = np.zeros_like(p)
  normal = np.zeros_like(p)
  for k, prim in enumerate(prims):
    m = (which == k) & hit
    if m.any():
      a, n = prim.surface(p[m])
      albedo[m], normal[m] = a, n
  shade = 0.35 + 0.65 * np.clip((normal * _LIGHT).sum(-1, keepdims=True), 0.0, 1.0)
  rgb = np.clip(albedo * shade, 0.0, 1.0)
  rgba = np.concatenate([np.where(hit[..., None], rgb, 0.0), hit[..., None].astype(float)], -1)
  return rgba, np.where(hit, t_hit, 0.0)


def _random_cameras(rng, n, azimuth, sin_elevation):
  return [camera.spherical_camera(RADIUS, rng.uniform(*azimuth),
                                  np.rad2deg(np.arcsin(rng.uniform(*sin_elevation))))
          for _ in range(n)]


def _poses(spec: Scene, rng, num_train, num_test, num_val):
  """{split: [c2w]}. Val is drawn after train from the same generator, so
  adding it left the train and test poses as they were."""
  train = _random_cameras(rng, num_train, spec.train_azimuth, spec.train_sin_elevation)
  test = [camera.spherical_camera(RADIUS, az, 30.0)
          for az in np.linspace(-180, 180, num_test, endpoint=False)]
  # Elevations off the test orbit's 30 degrees (sin 0.5): below or above it.
  val = [camera.spherical_camera(
      RADIUS, rng.uniform(-180.0, 180.0),
      np.rad2deg(np.arcsin(rng.choice([rng.uniform(0.15, 0.4), rng.uniform(0.6, 0.9)]))))
         for _ in range(num_val)]
  return {"train": train, "test": test, "val": val}


def generate(root: str, size: int = 100, num_train: int = 100, num_test: int = 200,
             seed: int = 0, scene: str = "spheres", num_val: int = 24) -> str:
  """Writes SCENES[scene] to `root` (skipped if already complete); returns root."""
  if scene not in SCENES:
    raise ValueError(f"data.procedural_scene={scene!r}: not one of {sorted(SCENES)}")
  done = os.path.join(root, ".complete_with_val")
  if os.path.exists(done):
    return root
  focal = 0.5 * size / np.tan(0.5 * CAMERA_ANGLE_X)
  poses_of = _poses(SCENES[scene], np.random.default_rng(seed), num_train, num_test, num_val)
  for split, poses in poses_of.items():
    os.makedirs(os.path.join(root, split), exist_ok=True)
    frames = []
    for i, c2w in enumerate(poses):
      o, d = camera.pixel_rays(c2w, size, size, focal)
      rgba, _ = render_rays(o.astype(np.float64), d.astype(np.float64), scene)
      image_files.write(os.path.join(root, split, f"r_{i}.png"),
                  np.round(rgba * 255).astype(np.uint8))
      frames.append({"file_path": f"./{split}/r_{i}", "transform_matrix": c2w.tolist()})
    with open(os.path.join(root, f"transforms_{split}.json"), "w") as f:
      json.dump({"camera_angle_x": CAMERA_ANGLE_X, "frames": frames}, f, indent=1)
  open(done, "w").close()
  return root
