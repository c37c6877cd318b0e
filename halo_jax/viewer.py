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
from typing import Any, Dict, Optional, Tuple

import numpy as np

from halo_jax import (camera, checkpoint, datasets, frozen, protocol, raycast, restore, samplers,
                      video, workdir_lock)
from halo_jax.datasets.base import Views
from halo_jax.datasets.llff import NDCViews
from halo_jax.datasets.stanford_lf import LightFieldViews
from halo_jax.stages import metrics_log
from halo_jax.geometry import Geometry
from halo_jax.stages import base, order, state, step as steps

OUTPUTS = ("color", "depth", "opacity")
# where a ray field places the stage's samples (guided stages: HALO's Hi)
GUIDE_OUTPUTS = ("ray field depth", "window misses")
CHUNK = 4096  # rays per jitted call: a 64x64 preview is one call


@dataclasses.dataclass(frozen=True)
class Camera:
  """c2w [4, 4] (OpenGL axes) and vertical field of view in radians, or uv
  [2] for light fields; time in [0, 1] for dynamic scenes."""
  c2w: Optional[np.ndarray] = None
  fov_y: float = 0.7
  uv: Optional[Tuple[float, float]] = None
  time: float = 0.0


def _read_run_config(workdir: str):
  path = os.path.join(workdir, "config.json")
  if not os.path.exists(path):
    raise restore.NothingToRestore(f"{workdir}: no run here (no config.json); train one first "
                                   "(halo-train --config=... --workdir=DIR)")
  # as the stages trained it (the protocol's plan laid over them), editable
  return frozen.thaw(protocol.effective(checkpoint.read_config(path)))


def _draws(config, name) -> bool:
  return base.trainer_of(config, name).renderer is not None


def drawable_stages(workdir: str):
  """The finished stages of the run in `workdir` that make images, in
  training order."""
  config = _read_run_config(workdir)
  return [n for n in order.needed(config) if restore.finished(workdir, n) and _draws(config, n)]


def training_stage(workdir: str):
  """(stage, step) of the stage in training with a checkpoint, or None."""
  config = _read_run_config(workdir)
  for n in order.needed(config):
    if restore.finished(workdir, n):
      continue
    folder = os.path.join(state.stage_dir(workdir, n), "checkpoints")
    saved = (checkpoint.manager(folder, max_to_keep=None).all_steps()
             if os.path.isdir(folder) else [])
    return (n, max(saved)) if saved else None
  return None


class FieldView:
  """The run in `workdir`: its finished stages that make images, each
  restored on first use, and the stage in training at its latest checkpoint
  (`refresh` looks again). NothingToRestore when there is nothing to show
  and no training holds the workdir."""

  def __init__(self, workdir: str, data_root: str = ""):
    self.workdir, self.data_root = workdir, data_root
    self.config = _read_run_config(workdir)
    if data_root:
      self.config.data.root = data_root
    self.dataset = datasets.load(self.config.data, workdir)
    self._runs: Dict[str, Any] = {}
    self._guides: Dict[str, Any] = {}
    self.stages, self.live = [], None
    self.refresh()
    if not self.stages and not workdir_lock.is_held(workdir):
      raise restore.NothingToRestore(f"{workdir}: no finished stage that makes images, and "
                                     "no training running there")

  def refresh(self) -> bool:
    """Looks for newly finished stages and checkpoints; True if any."""
    done = drawable_stages(self.workdir)
    live = training_stage(self.workdir)
    if live is not None and not _draws(self.config, live[0]):
      live = None  # the ray field makes no image of its own
    stages = done + ([live[0]] if live else [])
    changed = (stages, live) != (self.stages, self.live)
    if changed:
      self._runs = {n: r for n, r in self._runs.items() if n in done}
      self._guides = {n: g for n, g in self._guides.items() if n in done}
      self.stages, self.live = stages, live
    return changed

  def run(self, stage: str):
    """The stage's renderer holder (a restore.Restored, or the live one)."""
    if stage not in self._runs:
      if self.live and stage == self.live[0]:
        self._runs[stage] = _live_run(self, stage)
      else:
        self._runs[stage] = restore.load(self.workdir, stage, self.data_root)
    return self._runs[stage]

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

  def guide(self, stage: str):
    """(Guide, sampler config) of the ray field placing `stage`'s samples, or None."""
    if stage not in self._guides:
      run, trainer = self.run(stage), base.trainer_of(self.config, stage)
      self._guides[stage] = trainer.guide and trainer.guide(run.config, stage, self.dataset,
                                                            run.states)
    return self._guides[stage]

  def outputs(self, stage: str):
    return OUTPUTS + (GUIDE_OUTPUTS if self.guide(stage) else ())

  def draw(self, stage: str, cam: Camera, height: int, width: int, output: str = "color"):
    """uint8 [H, W, 3] of `output` (one of self.outputs(stage)) and the
    seconds it took."""
    if output not in self.outputs(stage):
      raise ValueError(f"output {output!r}: stage {stage} has {self.outputs(stage)}")
    t0 = time.perf_counter()
    r = self.render(stage, cam, height, width)
    if output in GUIDE_OUTPUTS:
      r = self._with_guide(stage, cam, r, height, width)
    return to_image(r, output), time.perf_counter() - t0

  def _with_guide(self, stage, cam, r, height, width):
    """r plus the ray field's depth on the same rays and where the stage's
    depth falls outside the window the guided sampler fills."""
    guide, sampler = self.guide(stage)
    o, d = self._views(cam, height, width).rays()
    depth, _ = raycast.ray_field_depth(guide, o[0], d[0])
    lo, hi = samplers.depth_window(depth, self.dataset.near, self.dataset.far, sampler.window,
                                   sampler.near_only)
    miss = (r["acc"] > 0.5) & ((r["depth"] < np.asarray(lo)) | (r["depth"] > np.asarray(hi)))
    return dict(r, ray_depth=np.asarray(depth), miss=np.asarray(miss))


@dataclasses.dataclass(frozen=True)
class LiveRun:
  """A stage in training drawn at one checkpoint: its step, renderer, config
  and the states it reads (as a restore.Restored has them)."""
  step: int
  render: Any
  config: Any
  states: Dict[str, Any]


def _live_run(field: FieldView, name: str) -> LiveRun:
  """The training stage `name` at its latest checkpoint, with the finished
  stages it reads, as the renderer its final evaluation will use."""
  config, ds = field.config, field.dataset
  trainer = base.trainer_of(config, name)
  like = steps.initial_state(trainer.params_like(config, name, ds),
                             steps.optimizer(config[name]))
  mngr = checkpoint.manager(os.path.join(state.stage_dir(field.workdir, name), "checkpoints"),
                            max_to_keep=None)
  at = field.live[1]
  params = checkpoint.restore(mngr, at, dict(like, wall_s=0.0))["params"]
  states = restore.stage_states(field.workdir, config, ds,
                                [n for n in order.needed(config, name) if n != name])
  states[name] = state.StageState(params, at, config, name)
  return LiveRun(at, base.renderer_of(config, name, ds, states), config, states)


def read_records(workdir: str):
  """metrics.jsonl's records so far (a line being written is skipped)."""
  return metrics_log.read(workdir)


def to_image(r, output: str) -> np.ndarray:
  """A render's colour, depth or opacity as uint8 [H, W, 3]."""
  if output == "color":
    return video.to_uint8(np.clip(r["rgb"], 0.0, 1.0))
  if output == "opacity":
    return video.to_uint8(np.repeat(np.clip(r["acc"], 0.0, 1.0)[..., None], 3, -1))
  if output == "window misses":  # the colour, greyed, red where the window misses
    grey = np.repeat(np.clip(r["rgb"], 0, 1).mean(-1, keepdims=True), 3, -1) * 0.6 + 0.2
    return video.to_uint8(np.where(r["miss"][..., None], [1.0, 0.1, 0.1], grey))
  seen = r["acc"] > 0.5
  lo, hi = np.percentile(r["depth"][seen], [1, 99]) if seen.any() else (0.0, 1.0)
  depth = r["ray_depth"] if output == "ray field depth" else r["depth"]
  return video.to_uint8(video.colorize(depth, lo, max(hi, lo + 1e-6), mask=seen))


def opencv_pose(c2w):
  """OpenGL camera-to-world [4, 4] -> (rotation [3, 3], position [3]) with
  OpenCV axes (x right, y down, looking down +z), as viser takes cameras."""
  cv = camera.opencv_to_opengl(c2w)  # its own inverse
  return cv[:3, :3], cv[:3, 3]


def opengl_c2w(rotation, position):
  """opencv_pose's inverse: [4, 4] OpenGL camera-to-world."""
  cv = np.eye(4)
  cv[:3, :3], cv[:3, 3] = rotation, position
  return camera.opencv_to_opengl(cv)


def fov_y(views) -> float:
  """The vertical field of view of a Views' pinhole camera, radians."""
  return float(2.0 * np.arctan(0.5 * views.height / views.focal))
