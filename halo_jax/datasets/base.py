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
    depth_bounds: NDC: [N, 2] near / far scene depth of every camera of the
      scene (LLFF's poses_bounds, scaled as the poses are), which place its
      spiral paths; else None.
  """
  train: Views
  test: Views
  near: float
  far: float
  radius: float
  white_background: bool = True
  geometry: Geometry = Geometry.SPHERE
  depth_bounds: Optional[np.ndarray] = None

  @property
  def dynamic(self) -> bool:
    """Whether frames carry capture times."""
    return getattr(self.train, "times", None) is not None


def camera_radius(c2w) -> float:
  return float(np.linalg.norm(np.asarray(c2w)[:, :3, 3], axis=-1).mean())

