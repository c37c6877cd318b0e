"""A run's finished stages drawn from any camera: what the browser viewer
(halo_jax/cli/view.py) shows, kept free of the viewer library so it can be
tested and timed alone.

A camera here is what the scene kind moves: a pose (camera-to-world, OpenGL
axes, the scene's frame) with a vertical field of view for sphere and NDC
scenes, a (u, v) point on the camera plane for light fields; dynamic scenes
add a time in [0, 1]. Outputs are colour, depth (turbo, near to far of the
visible pixels) and opacity, as uint8 [H, W, 3].
"""
import dataclasses
import os
import time
from typing import Dict, Optional, Tuple

import numpy as np

from halo_jax import checkpoint, raycast, restore, video
from halo_jax.datasets.base import Views
from halo_jax.datasets.llff import NDCViews
from halo_jax.datasets.stanford_lf import LightFieldViews
from halo_jax.geometry import Geometry
from halo_jax.stages import base, order

OUTPUTS = ("color", "depth", "opacity")
CHUNK = 4096  # rays per jitted call: a 64x64 preview is one call


@dataclasses.dataclass(frozen=True)
class Camera:
  """c2w [4, 4] (OpenGL axes) and vertical field of view in radians, or uv
  [2] for light fields; time in [0, 1] for dynamic scenes."""
  c2w: Optional[np.ndarray] = None
  fov_y: float = 0.7
  uv: Optional[Tuple[float, float]] = None
  time: float = 0.0


def drawable_stages(workdir: str):
  """The stages of the run in `workdir` that finished and make images, in
  training order; NothingToRestore when there is none."""
  path = os.path.join(workdir, "config.json")
  if not os.path.exists(path):
    raise restore.NothingToRestore(f"{workdir}: no run here (no config.json); train one first "
                                   "(halo-train --config=... --workdir=DIR)")
  config = checkpoint.read_config(path)
  names = [n for n in order.needed(config) if restore.finished(workdir, n)
           and base.trainer_of(config, n).renderer is not None]
  if not names:
    raise restore.NothingToRestore(f"{workdir}: no finished stage that makes images yet "
                                   "(the viewer shows a stage once it has finished)")
  return names


class FieldView:
  """The run in `workdir`, each drawable stage restored on first use."""

  def __init__(self, workdir: str, data_root: str = ""):
    self.workdir, self.data_root = workdir, data_root
    self.stages = drawable_stages(workdir)
    self._runs: Dict[str, restore.Restored] = {}

  def run(self, stage: str) -> restore.Restored:
    if stage not in self._runs:
      self._runs[stage] = restore.load(self.workdir, stage, self.data_root)
    return self._runs[stage]

  @property
  def dataset(self):
    return self.run(self.stages[-1]).dataset

  def _views(self, cam: Camera, height: int, width: int):
    ds = self.dataset
    if ds.geometry == Geometry.TWO_PLANE:
      uv = np.array([cam.uv if cam.uv is not None else ds.train.uv.mean(0)], np.float32)
      return LightFieldViews(np.zeros((1, height, width, 3), np.float32), uv, ("view",))
    focal = 0.5 * height / np.tan(0.5 * cam.fov_y)
    times = np.array([cam.time], np.float32) if ds.dynamic else None
    cls = NDCViews if ds.geometry == Geometry.NDC else Views
    return cls(np.zeros((1, height, width, 3), np.float32),
               np.asarray(cam.c2w, np.float32)[None], float(focal), ("view",), times)

  def render(self, stage: str, cam: Camera, height: int, width: int) -> Dict[str, np.ndarray]:
    """{'rgb' [H, W, 3], 'depth' [H, W], 'acc' [H, W], ...} of one camera."""
    views = self._views(cam, height, width)
    o, d = views.rays()
    t = views.ray_times() if views.times is not None else None
    out = raycast.render_chunked(self.run(stage).render, o, d, CHUNK, t)
    return {k: v[0] for k, v in out.items()}

  def draw(self, stage: str, cam: Camera, height: int, width: int, output: str = "color"):
    """uint8 [H, W, 3] of `output` (one of OUTPUTS) and the seconds it took."""
    if output not in OUTPUTS:
      raise ValueError(f"output {output!r}: use one of {OUTPUTS}")
    t0 = time.perf_counter()
    r = self.render(stage, cam, height, width)
    return to_image(r, output), time.perf_counter() - t0


def to_image(r, output: str) -> np.ndarray:
  """A render's colour, depth or opacity as uint8 [H, W, 3]."""
  if output == "color":
    return video.to_uint8(np.clip(r["rgb"], 0.0, 1.0))
  if output == "opacity":
    return video.to_uint8(np.repeat(np.clip(r["acc"], 0.0, 1.0)[..., None], 3, -1))
  seen = r["acc"] > 0.5
  lo, hi = np.percentile(r["depth"][seen], [1, 99]) if seen.any() else (0.0, 1.0)
  return video.to_uint8(video.colorize(r["depth"], lo, max(hi, lo + 1e-6), mask=seen))


def opencv_pose(c2w):
  """OpenGL camera-to-world [4, 4] -> (rotation [3, 3], position [3]) with
  OpenCV axes (x right, y down, looking down +z), as viser takes cameras."""
  c2w = np.asarray(c2w, np.float64)
  return c2w[:3, :3] @ np.diag([1.0, -1.0, -1.0]), c2w[:3, 3].copy()


def opengl_c2w(rotation, position):
  """opencv_pose's inverse: [4, 4] OpenGL camera-to-world."""
  out = np.eye(4)
  out[:3, :3] = np.asarray(rotation, np.float64) @ np.diag([1.0, -1.0, -1.0])
  out[:3, 3] = position
  return out


def fov_y(views) -> float:
  """The vertical field of view of a Views' pinhole camera, radians."""
  return float(2.0 * np.arctan(0.5 * views.height / views.focal))
