"""The in-memory dataset every loader returns, and rays built from it."""
import dataclasses
from typing import Optional, Tuple

import numpy as np

from halo_jax import camera
from halo_jax.geometry import Geometry


class DataError(ValueError):
  """Bad input data; the message names the file and the field."""


@dataclasses.dataclass(frozen=True)
class Views:
  """A set of posed images of one size.

  Attributes:
    images: [N, H, W, 3] float32 in [0, 1] (composited onto the background).
    c2w: [N, 4, 4] float32 camera-to-world matrices (OpenGL axes).
    focal: focal length in pixels.
    names: N view names (e.g. "r_2").
    times: [N] float32 capture times in [0, 1] (dynamic scenes) or None.
  """
  images: np.ndarray
  c2w: np.ndarray
  focal: float
  names: Tuple[str, ...]
  times: Optional[np.ndarray] = None

  @property
  def height(self) -> int:
    return self.images.shape[1]

  @property
  def width(self) -> int:
    return self.images.shape[2]

  def rays(self):
    """All pixel rays: origins [N, H, W, 3], directions [N, H, W, 3]."""
    o, d = zip(*(camera.pixel_rays(c, self.height, self.width, self.focal) for c in self.c2w))
    return np.stack(o), np.stack(d)

  def ray_times(self):
    """Each pixel ray's time [N, H, W, 1], or None for a static scene."""
    if self.times is None:
      return None
    return np.broadcast_to(self.times[:, None, None, None].astype(np.float32),
                           (*self.images.shape[:3], 1))


@dataclasses.dataclass(frozen=True)
class SceneFacts:
  """What a scene kind's rays mean, declared by its registry entry
  (datasets.LOADERS) for the code that moves cameras or reads depth.

  Attributes:
    pair_kind: the view_pairs.PAIR_KINDS entry the frequency rule renders
      nearby views with ('' for none: the rule cannot run on this kind).
    path_kinds: camera_paths names the render command takes, the default first.
    depth_units: what a rendered depth measures (written beside predictions).
  """
  pair_kind: str
  path_kinds: Tuple[str, ...]
  depth_units: str


_DISTANCE = "distance along the unit-norm ray (scene units)"
# Cameras round an object: orbits (and, with times, a fixed camera through time).
ORBIT = SceneFacts("orbit", ("orbit",), _DISTANCE)
ORBIT_TIME = SceneFacts("orbit_time", ("orbit_time", "time", "orbit"), _DISTANCE)
# Forward-facing cameras in NDC: spirals in front of the scene.
SPIRAL = SceneFacts("spiral", ("spiral",), "NDC ray parameter t in [0, 1]")
# A two-plane light field: moves on the camera plane.
UV_PLANE = SceneFacts("uv", ("uv",), "EPI ray parameter tau in [0, 1]")


@dataclasses.dataclass(frozen=True)
class Dataset:
  """Training and held-out views of one scene plus its bounds.

  Attributes:
    train, test: Views (for TWO_PLANE, stanford_lf.LightFieldViews).
    near, far: bounds of the ray parameter, which the geometry defines:
      scene distance t (SPHERE), NDC t in [0, 1] (NDC), the EPI angle theta
      (TWO_PLANE: theta_n, theta_f).
    radius: SPHERE: camera radius (mean distance of training cameras from
      the origin), the sphere on which the ray field enters rays; else 0.
    white_background: images were composited onto white.
    geometry: what a ray is (halo_jax.geometry.Geometry).
    depth_bounds: LLFF (NDC, llff_planes): [N, 2] near / far scene depth of
      every camera of the scene (LLFF's poses_bounds, scaled as the poses
      are), which place its spiral paths; else None.
    facts: its kind's SceneFacts (datasets.load sets its registry entry's).
    epi_slope: TWO_PLANE: how near / far read (lightfield.SLOPES): EPI angles
      ('angle'), or distances from the (u, v) plane ('depth').
    select: the views model selection scores on (data.select_views), or None.
  """
  train: Views
  test: Views
  near: float
  far: float
  radius: float
  white_background: bool = True
  geometry: Geometry = Geometry.SPHERE
  depth_bounds: Optional[np.ndarray] = None
  facts: SceneFacts = ORBIT
  epi_slope: str = "angle"
  select: Optional[Views] = None

  @property
  def dynamic(self) -> bool:
    """Whether frames carry capture times."""
    return getattr(self.train, "times", None) is not None


@dataclasses.dataclass(frozen=True)
class Similarity:
  """How a loader moved a scene into its frame: p' = scale * rotation @ p + shift.

  Attributes:
    rotation: [3, 3]; scale: a positive float; shift: [3].
  """
  rotation: np.ndarray
  scale: float
  shift: np.ndarray

  @classmethod
  def identity(cls):
    return cls(np.eye(3), 1.0, np.zeros(3))

  def poses(self, c2w):
    """Camera-to-world [..., 3 or 4, 4] in the new frame, [..., 4, 4] float64."""
    c2w = np.asarray(c2w, np.float64)
    out = np.broadcast_to(np.eye(4), c2w.shape[:-2] + (4, 4)).copy()
    out[..., :3, :3] = self.rotation @ c2w[..., :3, :3]
    out[..., :3, 3] = self.scale * c2w[..., :3, 3] @ self.rotation.T + self.shift
    return out

  def points(self, points):
    """Points [..., 3] in the new frame."""
    return self.scale * np.asarray(points, np.float64) @ self.rotation.T + self.shift


def camera_radius(c2w) -> float:
  return float(np.linalg.norm(np.asarray(c2w)[:, :3, 3], axis=-1).mean())


def view_names(spec, split_names):
  """A view list from the config: a list/tuple of names, 'all', 'every:K'
  (every K-th view from the first), or 'spread:N/K' (N views spread evenly
  over the ones 'every:K' leaves out: RegNeRF's few-shot split, see
  spread_views)."""
  if spec in (None, "all"):
    return None
  if isinstance(spec, str) and spec.startswith("every:"):
    return list(split_names)[::int(spec.split(":")[1])]
  if isinstance(spec, str) and spec.startswith("spread:"):
    num, _, hold = spec.split(":")[1].partition("/")
    return spread_views(list(split_names), int(num), int(hold))
  if isinstance(spec, str):
    return [s for s in spec.split(",") if s]
  return list(spec)


def spread_views(names, num: int, hold: int):
  """RegNeRF's few-shot training views (google-research/regnerf,
  internal/datasets.py, LLFF): every `hold`-th view is held out, and `num`
  of the rest are taken at round(linspace(0, len - 1, num)), Python's round
  (halves to even) as there."""
  rest = [n for i, n in enumerate(names) if i % hold != 0]
  if not 0 < num <= len(rest):
    raise DataError(f"'spread:{num}/{hold}': {len(rest)} views are left after holding out "
                    f"every {hold}-th of {len(names)}")
  return [rest[round(float(i))] for i in np.linspace(0, len(rest) - 1, num)]
