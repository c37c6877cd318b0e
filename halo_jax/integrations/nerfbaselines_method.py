"""HALO (and every method of halo_jax.methods) behind nerfbaselines' Method
interface: train_iteration(step), render(camera), save(path).

nerfbaselines runs this class in an environment of its own (its conda
backend, or halo_jax/integrations/nerfbaselines_venv.py for an existing
virtual environment) and talks to it over its RPC; nothing here runs in
nerfbaselines' own process, so numpy and jax are ours.

Training is our pipeline, unchanged: its stages run on a thread of their own
whose loop takes one step each time nerfbaselines calls train_iteration
(stages/pacing.py), so Lo-NeRF, the ray field and Hi-NeRF are one run of
sum(steps) iterations. Config overrides (`nerfbaselines train --set k=v`,
docs/capture.md): config=FILE.py:VARIANT (the config the run starts from;
only its method and model sections matter, the views are nerfbaselines'),
cpu=True, scene_kind=KIND (object, capture or forward) and a.b.c=VALUE.

A checkpoint is our workdir, copied, beside halo-nerfbaselines.json (the
config and the frame the scene was moved into) and scene.npz (the training
views, so a checkpoint renders without the dataset).
"""
import ast
import json
import logging
import os
import shutil
import tempfile
from typing import Any, Dict, Optional

from absl import logging as absl_logging
import ml_collections
import numpy as np

from halo_jax import checkpoint as checkpoints, config_files, configure, frozen, pipeline, protocol, raycast
from halo_jax import restore
from halo_jax.datasets.base import Dataset, Similarity, Views
from halo_jax.geometry import Geometry
from halo_jax.integrations import nerfbaselines_scene as nb_scene
from halo_jax.integrations.nerfbaselines_info import method_info
from halo_jax.registry import ConfigError
from halo_jax.stages import base, budget, order, pacing, state

DEFAULT_CONFIGS = {"object": "blender.py:lego_8view", "capture": "capture.py:8view",
                   "forward": "capture.py:8view_ff"}
DATA_KINDS = {"object": "blender", "capture": "capture", "forward": "capture_ff"}
META_FILE = "halo-nerfbaselines.json"
SCENE_FILE = "scene.npz"
WORKDIR = "halo"


def make_config(kind: str, overrides: Dict[str, Any]):
  """Our config for a harness run: the named or default config as the method
  the harness's `method` names (HALO by default), the harness's overrides, step-capped stages (nerfbaselines counts iterations, not
  seconds) and no held-out scoring of our own (the harness scores)."""
  overrides = {k: parse_value(v) for k, v in overrides.items()}
  cpu = bool(overrides.pop("cpu", False))
  spec = overrides.pop("config", None) or DEFAULT_CONFIGS[kind] + ("_cpu" if cpu else "")
  method = overrides.pop("method", "halo")
  # no held-out scoring of ours (the harness scores; the error-against-time
  # front is our benchmark's), then the harness's --set fields
  def fields_of(config):
    ours = {"eval.lpips": False, "eval.save_images": False, "eval.front_s": (),
            **{f"{n}.eval_every": 0 for n in order.stage_names(config)}}
    return {**ours, **overrides}
  try:
    if isinstance(spec, ml_collections.ConfigDict):  # a method's config, handed over (tests)
      config, spec = protocol.steps(frozen.thaw(spec)), "(a ConfigDict)"
      for field, value in fields_of(config).items():
        configure.set_field(config, field, value)
      return configure.finish(config), spec
    scene = configure.load_scene(spec)
    scene.data.kind = DATA_KINDS[kind]   # the harness's scene, read by our loader of its kind
    first = configure.compose(scene, method, overrides, protocol="steps")
    return configure.compose(scene, method, fields_of(first), protocol="steps"), spec
  except KeyError as e:
    raise ConfigError(f"nerfbaselines --set: our config ({spec}): {e.args[0]}") from e


def parse_value(value):
  """A `--set k=v` value as the Python value it spells (nerfbaselines passes
  the text): 30 -> int, 1e-3 -> float, true / True -> bool, else the text."""
  if not isinstance(value, str):
    return value
  if value.lower() in ("true", "false"):
    return value.lower() == "true"
  try:
    return ast.literal_eval(value)
  except (ValueError, SyntaxError):
    return value


def _save_scene(path: str, scene: nb_scene.Scene) -> None:
  ds = scene.dataset
  np.savez_compressed(
      path, images=np.round(ds.train.images * 255).astype(np.uint8), c2w=ds.train.c2w,
      focal=ds.train.focal, near=ds.near, far=ds.far, radius=ds.radius,
      white=ds.white_background, geometry=ds.geometry.value,
      depth_bounds=np.zeros(0) if ds.depth_bounds is None else ds.depth_bounds)


def _load_scene(path: str, meta: dict) -> nb_scene.Scene:
  z = np.load(path)
  names = tuple(f"{i:03d}" for i in range(len(z["c2w"])))
  cls = nb_scene.llff.NDCViews if meta["kind"] == "forward" else Views
  views = cls(z["images"].astype(np.float32) / 255.0, z["c2w"], float(z["focal"]), names)
  geometry = Geometry(str(z["geometry"]))
  bounds = z["depth_bounds"] if z["depth_bounds"].size else None
  facts = nb_scene.SPIRAL if meta["kind"] == "forward" else nb_scene.ORBIT
  ds = Dataset(views, nb_scene.first_view(views), float(z["near"]), float(z["far"]),
               float(z["radius"]), bool(z["white"]), geometry, bounds, facts)
  frame = Similarity(np.array(meta["frame"]["rotation"]), float(meta["frame"]["scale"]),
                     np.array(meta["frame"]["shift"]))
  return nb_scene.Scene(ds, meta["kind"], frame, tuple(meta["ndc_camera"]))


class HaloMethod:
  """A nerfbaselines Method (duck-typed: nerfbaselines' Protocol is not
  imported, so this module loads where nerfbaselines is absent)."""

  def __init__(self, *, checkpoint: Optional[str] = None, train_dataset=None,
               config_overrides: Optional[Dict[str, Any]] = None):
    # orbax logs every save at INFO, the level nerfbaselines gives its worker
    absl_logging.set_verbosity(absl_logging.WARNING)
    logging.getLogger("absl").setLevel(logging.WARNING)
    self.workdir = tempfile.mkdtemp(prefix="halo-nerfbaselines-")
    self.checkpoint = checkpoint
    meta = {}
    if checkpoint is not None:
      with open(os.path.join(checkpoint, META_FILE)) as f:
        meta = json.load(f)
      shutil.copytree(os.path.join(checkpoint, WORKDIR), self.workdir, dirs_exist_ok=True)
    overrides = dict(config_overrides or {})
    kind = overrides.pop("scene_kind", "") or meta.get("kind", "")
    if train_dataset is not None:
      self.scene = nb_scene.to_scene(train_dataset, kind)
    elif checkpoint is not None:
      self.scene = _load_scene(os.path.join(checkpoint, SCENE_FILE), meta)
    else:
      raise ValueError("HaloMethod needs a train_dataset or a checkpoint")
    saved = os.path.join(self.workdir, "config.json")
    if os.path.exists(saved):  # a checkpoint's run goes on with its own config
      self.config = frozen.freeze(checkpoints.read_config(saved))
      self.config_spec = meta.get("config", "")
    else:
      self.config, self.config_spec = make_config(self.scene.kind, overrides)
    # the stages as they train (the protocol's plan laid over them): what a
    # stage's parameters, renderer and step count are read from
    self.trained = protocol.effective(self.config)
    self.loaded_step = meta.get("step")
    self._paced: Optional[pacing.Paced] = None
    self._last: Optional[pacing.StepRecord] = None
    self._renderers: Dict[Any, Any] = {}

  @classmethod
  def get_method_info(cls):
    return method_info()

  def get_info(self):
    return {**method_info(), "num_iterations": self.num_iterations(),
            "loaded_step": self.loaded_step, "loaded_checkpoint": self.checkpoint,
            "batch_size": int(self.config.hi.batch_rays), "eval_batch_size": self.config.eval.chunk,
            "hparams": config_files.dotted_fields(self.config.to_dict())}

  def num_iterations(self) -> int:
    """One iteration a training step of each stage the method's output needs."""
    return sum(budget.last_step(self.trained[n]) for n in order.needed(self.trained))

  # Training.
  def train_iteration(self, step: int) -> Dict[str, float]:
    del step  # our stages count their own steps, resumed from the workdir
    if self._paced is None:
      config, scene = self.config, self.scene
      self._paced = pacing.Paced(
          lambda pacer: pipeline.run(config, self.workdir, scene.dataset, pacer))
    record = self._paced.step()
    if record is None:
      return {}
    self._last = record
    self._renderers.pop("live", None)
    return {**record.metrics, "stage": float(order.needed(self.config).index(record.stage))}

  # Rendering.
  def _finished_states(self):
    """{name: StageState} of the stages finished in the workdir."""
    return restore.stage_states(self.workdir, self.trained, self.scene.dataset,
                                [n for n in order.needed(self.config)
                                 if restore.finished(self.workdir, n)])

  def _renderer(self):
    """fn(o, d) -> {'rgb', 'depth', 'acc'} of the newest field: the stage in
    training (its parameters after the last step) or the last finished one."""
    live = self._last is not None and not (self._paced and self._paced.finished)
    key = "live" if live else "final"
    if key not in self._renderers:
      states = self._finished_states()
      names = list(states)
      if live:
        rec = self._last
        states[rec.stage] = state.StageState(rec.params, rec.step, self.trained, rec.stage)
        names.append(rec.stage)
      drawn = [n for n in names if base.trainer_of(self.trained, n).renderer is not None]
      if not drawn:
        raise RuntimeError("nothing to render yet: no stage that makes images has a step")
      name = drawn[-1]
      self._renderers[key] = base.renderer_of(self.trained, name, self.scene.dataset, states)
    return self._renderers[key]

  def render(self, camera, *, options=None) -> Dict[str, np.ndarray]:
    """color [H, W, 3] float32 in [0, 1], depth [H, W] (scene units of the
    harness; sphere scenes only) and accumulation [H, W] of one camera."""
    del options
    cam = camera.item() if hasattr(camera, "item") else camera
    o, d = nb_scene.camera_rays(self.scene, cam.poses, cam.intrinsics, cam.image_sizes)
    out = raycast.render_chunked(self._renderer(), o, d, self.config.eval.chunk)
    result = {"color": np.clip(out["rgb"], 0.0, 1.0).astype(np.float32),
              "accumulation": out["acc"].astype(np.float32)}
    if self.scene.dataset.geometry == Geometry.SPHERE:
      result["depth"] = (out["depth"] / self.scene.frame.scale).astype(np.float32)
    return result

  def render_views(self, views) -> np.ndarray:
    """Our Views (the scene's own cameras) drawn by the same field: [N, H, W, 3]."""
    o, d = views.rays()
    return np.clip(raycast.render_chunked(self._renderer(), o, d, self.config.eval.chunk)["rgb"],
                   0.0, 1.0)

  # Checkpoints.
  def _settle(self):
    """The workdir holds the state at the last step taken: the run's end, or
    a checkpoint of the stage in training at its current step."""
    if self._paced is None:
      return self.loaded_step or 0
    taken = self.num_iterations() if self._paced.finished else None
    if taken is None and self._last is not None and self._is_last(self._last):
      self._paced.join()
      self._renderers.pop("live", None)
      taken = self.num_iterations()
    if taken is None:
      self._paced.pacer.call(_checkpoint_now)
      taken = self._taken()
    return taken

  def _is_last(self, rec) -> bool:
    names = order.needed(self.config)
    return rec.stage == names[-1] and rec.step == budget.last_step(self.trained[names[-1]])

  def _taken(self) -> int:
    """Iterations taken so far: finished stages' steps and the current stage's."""
    names, rec = order.needed(self.config), self._last
    done = names[:names.index(rec.stage)]
    return sum(budget.last_step(self.trained[n]) for n in done) + rec.step

  def save(self, path: str) -> None:
    step = self._settle()
    os.makedirs(path, exist_ok=True)
    if not os.path.exists(os.path.join(self.workdir, "config.json")):  # saved before training
      checkpoints.write_config(os.path.join(self.workdir, "config.json"), self.config)
    shutil.copytree(self.workdir, os.path.join(path, WORKDIR), dirs_exist_ok=True)
    _save_scene(os.path.join(path, SCENE_FILE), self.scene)
    frame = self.scene.frame
    meta = {"kind": self.scene.kind, "config": self.config_spec,
            "step": step, "ndc_camera": list(self.scene.ndc_camera),
            "frame": {"rotation": np.asarray(frame.rotation).tolist(), "scale": frame.scale,
                      "shift": np.asarray(frame.shift).tolist()}}
    with open(os.path.join(path, META_FILE), "w") as f:
      json.dump(meta, f, indent=1)


def _checkpoint_now(run) -> None:
  """On the training thread: a checkpoint of the stage at its current step."""
  step = int(run.state["step"])
  if run.mngr.latest_step() != step:
    run.save(step)
