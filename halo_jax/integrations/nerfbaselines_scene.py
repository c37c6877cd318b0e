"""A nerfbaselines dataset as our Dataset, and its cameras as our rays.

nerfbaselines hands a method its training split: images (uint8, RGB or RGBA),
OpenCV camera-to-world poses [N, 3, 4], pinhole intrinsics (fx, fy, cx, cy),
image sizes, per-camera near / far and, for captures, sparse points. The
scene is put in the frame our loaders use for its kind:

  object     the Blender layout (a background colour and one near / far for
             every camera): coordinates kept, images composited on the
             background, sphere rays between the given near and far;
  capture    a 360-degree capture: capture.sphere_frame (centred, +z up,
             cameras at the Blender radius), near / far from the points;
  forward    a forward-facing capture: LLFF's normalisation and NDC rays,
             depth bounds from nears_fars or the points.

The kind is detected (`kind_of`) unless the method's config names it. The
Similarity that moved the scene is kept, so a camera nerfbaselines asks to
render, and the depth rendered back, are in the harness's own units.
"""
import dataclasses
from typing import Tuple

import numpy as np

from halo_jax import camera
from halo_jax.datasets import capture, llff, posed_photos
from halo_jax.datasets.base import (ORBIT, SPIRAL, DataError, Dataset, Similarity, Views,
                                    camera_radius)
from halo_jax.geometry import Geometry

KINDS = ("object", "capture", "forward")
# nerfbaselines' camera model ids (nerfbaselines.cameras.camera_model_to_int)
PINHOLE_MODEL = 0


@dataclasses.dataclass(frozen=True)
class Scene:
  """A nerfbaselines scene in our frame: the dataset, its kind, the
  Similarity from the harness's world to ours, and the training camera
  (height, width, focal) that NDC rays are defined by."""
  dataset: Dataset
  kind: str
  frame: Similarity
  ndc_camera: Tuple[int, int, float]


def kind_of(nb) -> str:
  """'object' for the Blender layout, else 'forward' or 'capture' by where
  the cameras look."""
  meta, cams = nb.get("metadata", {}), nb["cameras"]
  nf = cams.nears_fars
  if meta.get("background_color") is not None and nf is not None and np.allclose(nf, nf[:1]):
    return "object"
  return "forward" if capture.forward_facing(camera.opencv_to_opengl(cams.poses)) else "capture"


def _images(nb):
  """[N, H, W, 3] float32 in [0, 1], RGBA composited on the background."""
  images = [np.asarray(im) for im in nb["images"]]
  sizes = {im.shape[:2] for im in images}
  if len(sizes) != 1:
    raise DataError(f"nerfbaselines dataset: images of {len(sizes)} sizes {sorted(sizes)[:3]}; "
                    "one size is supported")
  bg = nb.get("metadata", {}).get("background_color")
  bg = np.zeros(3) if bg is None else np.asarray(bg, np.float64)[:3] / 255.0
  out = []
  for im in images:
    im = im.astype(np.float64) / (255.0 if im.dtype == np.uint8 else 1.0)
    if im.shape[-1] == 4:
      im = im[..., :3] * im[..., 3:] + bg * (1.0 - im[..., 3:])
    out.append(im[..., :3])
  return np.stack(out).astype(np.float32)


def _focal(nb, height, width):
  """The one centred square-pixel pinhole all cameras share (posed_photos.one_pinhole)."""
  cams = nb["cameras"]
  rows = []
  for i, (model, (fx, fy, cx, cy)) in enumerate(zip(cams.camera_models, cams.intrinsics)):
    name = "PINHOLE" if int(model) == PINHOLE_MODEL else f"model {int(model)}"
    rows.append((str(i), name, float(fx), float(fy), float(cx), float(cy), width, height))
  focal, _, _ = posed_photos.one_pinhole("nerfbaselines dataset", rows)
  return focal


def to_scene(nb, kind: str = "") -> Scene:
  """Our Scene of a nerfbaselines training dataset (kind '' = kind_of)."""
  kind = kind or kind_of(nb)
  if kind not in KINDS:
    raise DataError(f"scene_kind={kind!r}: use one of {list(KINDS)}")
  images = _images(nb)
  n, h, w = images.shape[:3]
  focal = _focal(nb, h, w)
  c2w = camera.opencv_to_opengl(nb["cameras"].poses)
  names = tuple(f"{i:03d}" for i in range(n))
  points = nb.get("points3D_xyz")
  white = bool(nb.get("metadata", {}).get("background_color") is not None
               and np.all(np.asarray(nb["metadata"]["background_color"])[:3] == 255))
  if kind == "object":
    near, far = (float(x) for x in nb["cameras"].nears_fars[0])
    frame = Similarity.identity()
    views = Views(images, c2w.astype(np.float32), focal, names)
    ds = Dataset(views, first_view(views), near, far, camera_radius(c2w), white, Geometry.SPHERE)
  elif kind == "capture":
    cap = posed_photos.Capture(names, names, c2w, focal, w, h, points)
    c2w, _, near, far, frame = capture.to_sphere(cap)
    views = Views(images, c2w.astype(np.float32), focal, names)
    ds = Dataset(views, first_view(views), near, far, camera_radius(c2w), white, Geometry.SPHERE)
  else:
    nf = nb["cameras"].nears_fars
    if nf is None:
      cap = posed_photos.Capture(names, names, c2w, focal, w, h, points)
      nf = capture.forward_bounds(cap)
    frame = llff.forward_frame(c2w, np.asarray(nf, np.float64))
    views = llff.NDCViews(images, frame.poses(c2w).astype(np.float32), focal, names)
    ds = Dataset(views, first_view(views), 0.0, 1.0, 0.0, white, Geometry.NDC,
                 depth_bounds=np.asarray(nf) * frame.scale, facts=SPIRAL)
  if kind != "forward":
    ds = dataclasses.replace(ds, facts=ORBIT)
  return Scene(ds, kind, frame, (h, w, focal))


def first_view(views):
  """The first training view, as the stages' own end-of-stage check: the
  harness scores held-out views itself."""
  return dataclasses.replace(views, images=views.images[:1], c2w=views.c2w[:1],
                             names=views.names[:1])


def camera_rays(scene: Scene, pose, intrinsics, size):
  """Rays of one nerfbaselines camera in our frame: origins, directions
  [H, W, 3] (NDC for a forward scene), for OpenCV pose [3, 4], intrinsics
  (fx, fy, cx, cy) and size (width, height)."""
  width, height = (int(v) for v in size)
  c2w = scene.frame.poses(camera.opencv_to_opengl(pose))
  o, d = camera.pinhole_rays(c2w, height, width, intrinsics)
  if scene.dataset.geometry == Geometry.NDC:
    h, w, focal = scene.ndc_camera
    o, d = camera.ndc_rays(o, d, h, w, focal)
  return o, d
