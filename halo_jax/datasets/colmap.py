"""COLMAP models through pycolmap, the COLMAP project's bindings: reading a
model (binary or text), undistorting its photos, and structure-from-motion
on a folder of photos (features, exhaustive matching, incremental mapping,
on the CPU)."""
import os
from typing import Optional

import numpy as np
import tqdm

from halo_jax.datasets.base import DataError
from halo_jax.datasets.posed_photos import IMAGE_EXT, UNDISTORTED, Capture, one_pinhole


SFM_SEED = 0


def _pycolmap():
  try:
    import pycolmap  # pylint: disable=g-import-not-at-top
  except ImportError:
    raise DataError("reading a COLMAP model or running structure-from-motion needs pycolmap: "
                    "pip install -e '.[capture]'") from None
  pycolmap.logging.minloglevel = 2  # COLMAP's own progress lines: errors only
  return pycolmap


def image_folder(root: str) -> str:
  """root/images if it holds photos, else root itself."""
  for folder in (os.path.join(root, "images"), root):
    if os.path.isdir(folder) and any(f.lower().endswith(IMAGE_EXT) for f in os.listdir(folder)):
      return folder
  raise DataError(f"{root}: no transforms.json, no COLMAP model (sparse/) and no photos "
                  f"({', '.join(IMAGE_EXT)}) in images/ or the folder itself")


def model_folder(root: str) -> Optional[str]:
  """The COLMAP model under root (sparse/0 or sparse/), or None."""
  for folder in (os.path.join(root, "sparse", "0"), os.path.join(root, "sparse")):
    if any(os.path.exists(os.path.join(folder, f"cameras.{e}")) for e in ("bin", "txt")):
      return folder
  return None


def run_sfm(root: str) -> str:
  """Structure-from-motion on the photos of `root` (one shared camera), the
  largest model written to root/sparse/0; returns that folder. Seeded
  (SFM_SEED): COLMAP's default seeds its RANSAC and mapper from the clock, so
  the same photos could register differently from one launch to the next."""
  pycolmap = _pycolmap()
  pycolmap.set_random_seed(SFM_SEED)
  images = image_folder(root)
  work = os.path.join(root, "colmap")
  os.makedirs(work, exist_ok=True)
  db = os.path.join(work, "database.db")
  if os.path.exists(db):  # a run stopped half-way: start over
    os.remove(db)
  maps = {}
  steps = ("features", "matching", "mapping")
  with tqdm.tqdm(steps, desc="structure-from-motion", unit="step") as bar:
    for step in bar:
      bar.set_postfix_str(step)
      if step == "features":
        options = pycolmap.FeatureExtractionOptions()
        options.use_gpu = False
        pycolmap.extract_features(db, images, camera_mode=pycolmap.CameraMode.SINGLE,
                                  extraction_options=options, device=pycolmap.Device.cpu)
      elif step == "matching":
        pycolmap.match_exhaustive(db, device=pycolmap.Device.cpu)
      else:
        mapper = pycolmap.IncrementalPipelineOptions()
        mapper.random_seed = SFM_SEED
        maps = pycolmap.incremental_mapping(db, images, work, options=mapper)
  if not maps:
    raise DataError(f"{images}: structure-from-motion registered no cameras (too little "
                    "texture or overlap between the photos)")
  best = max(maps.values(), key=lambda r: r.num_reg_images())
  out = os.path.join(root, "sparse", "0")
  os.makedirs(out, exist_ok=True)
  best.write(out)
  return out


def _undistorted(pycolmap, root, model, images):
  """(model, images) of the capture undistorted to pinhole cameras (cached)."""
  out = os.path.join(root, "undistorted")
  if not os.path.exists(os.path.join(out, ".complete")):
    pycolmap.undistort_images(out, model, images)
    open(os.path.join(out, ".complete"), "w").close()
  return os.path.join(out, "sparse"), os.path.join(out, "images")


_GL_FROM_CV = np.diag([1.0, -1.0, -1.0, 1.0])


def read_colmap(root: str, model: str) -> Capture:
  """The registered images of the COLMAP model in `model` (undistorted first
  where their camera has distortion)."""
  pycolmap = _pycolmap()
  images = image_folder(root)
  rec = pycolmap.Reconstruction(model)
  if any(c.model.name in UNDISTORTED and not c.is_undistorted() for c in rec.cameras.values()):
    model, images = _undistorted(pycolmap, root, model, images)
    rec = pycolmap.Reconstruction(model)
  regs = sorted((im for im in rec.images.values() if im.has_pose), key=lambda im: im.name)
  if len(regs) < 2:
    raise DataError(f"{model}: {len(regs)} registered images; a capture needs at least 2")
  cams = []
  for im in regs:
    c = im.camera
    fx, fy = c.focal_length_x, c.focal_length_y
    kind = "PINHOLE" if c.model.name in UNDISTORTED and c.is_undistorted() else c.model.name
    cams.append((im.name, kind, fx, fy, c.principal_point_x, c.principal_point_y, c.width,
                 c.height))
  focal, w, h = one_pinhole(model, cams)
  c2w = np.stack([np.linalg.inv(np.concatenate(
      [im.cam_from_world().matrix(), [[0, 0, 0, 1.0]]], 0)) @ _GL_FROM_CV for im in regs])
  points = np.array([p.xyz for p in rec.points3D.values()], np.float64).reshape(-1, 3)
  return Capture(tuple(os.path.splitext(im.name)[0] for im in regs),
                 tuple(os.path.join(images, im.name) for im in regs), c2w, focal, w, h,
                 points if len(points) else None)


