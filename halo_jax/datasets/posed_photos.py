"""Posed photos as read from disk, before any normalisation: the record the
capture readers return, the one-camera check they share, and nerfstudio's
transforms.json (datasets/colmap.py reads COLMAP models)."""
import dataclasses
import json
import os
from typing import Optional, Tuple

import numpy as np

from halo_jax.datasets import blender
from halo_jax.datasets.base import DataError

IMAGE_EXT = (".png", ".jpg", ".jpeg")
UNDISTORTED = ("SIMPLE_RADIAL", "RADIAL", "OPENCV")
PINHOLES = ("PINHOLE", "SIMPLE_PINHOLE")


@dataclasses.dataclass(frozen=True)
class Capture:
  """Posed photos before any normalisation.

  names: N view names (file names without folder or extension); paths: their files;
  c2w: [N, 4, 4] camera-to-world, OpenGL axes; focal, width, height: the one
  pinhole camera; points: [P, 3] sparse scene points, or None.
  """
  names: Tuple[str, ...]
  paths: Tuple[str, ...]
  c2w: np.ndarray
  focal: float
  width: int
  height: int
  points: Optional[np.ndarray]


def one_pinhole(where, cameras):
  """(focal, width, height) of the one centred square-pixel pinhole all
  `cameras` [(name, model, fx, fy, cx, cy, w, h)] share; DataError else."""
  name, model, fx, fy, cx, cy, w, h = cameras[0]
  for cam in cameras:
    n, m, cfx, cfy, ccx, ccy, cw, ch = cam
    if m not in PINHOLES:
      raise DataError(f"{where}: camera {n} is {m}; this loader takes {list(PINHOLES)} and "
                      f"undistorts {list(UNDISTORTED)}")
    if (cw, ch) != (w, h) or abs(cfx - fx) > 1e-3 * fx or abs(cfy - fy) > 1e-3 * fy:
      raise DataError(f"{where}: camera {n} ({m} {cw}x{ch}, f={cfx:.2f},{cfy:.2f}) differs "
                      f"from camera {name} ({w}x{h}, f={fx:.2f},{fy:.2f}); one shared camera "
                      "is supported")
    if abs(cfx - cfy) > 1e-3 * cfx or abs(ccx - cw / 2) > 1.0 or abs(ccy - ch / 2) > 1.0:
      raise DataError(f"{where}: camera {n} ({m} fx={cfx:.2f} fy={cfy:.2f} cx={ccx:.1f} "
                      f"cy={ccy:.1f}, {cw}x{ch}) needs square pixels and a principal point "
                      "at the image centre")
  return float(fx), int(w), int(h)


def read_transforms(root: str) -> Capture:
  """nerfstudio's transforms.json (OpenGL camera-to-world; intrinsics at the
  top level or per frame; any distortion refused)."""
  path = os.path.join(root, "transforms.json")
  try:
    with open(path) as f:
      meta = json.load(f)
  except (OSError, json.JSONDecodeError) as e:
    raise DataError(f"{path}: cannot read ({e})") from None
  frames = meta.get("frames")
  if not frames:
    raise DataError(f"{path}: no 'frames'")
  cams, names, paths, c2w = [], [], [], []
  for i, fr in enumerate(frames):
    get = lambda k, d=None: fr.get(k, meta.get(k, d))  # pylint: disable=cell-var-from-loop
    name = os.path.splitext(os.path.basename(fr.get("file_path", f"frame {i}")))[0]
    dist = {k: get(k, 0.0) for k in ("k1", "k2", "k3", "k4", "p1", "p2")}
    if any(dist.values()):
      raise DataError(f"{path}: frame {name} has camera_model {get('camera_model', 'OPENCV')!r} "
                      f"with distortion {dist}; undistort the images first (this loader takes "
                      "pinhole frames)")
    try:
      cams.append((name, "PINHOLE", float(get("fl_x")), float(get("fl_y", get("fl_x"))),
                   float(get("cx", get("w", 0) / 2)), float(get("cy", get("h", 0) / 2)),
                   int(get("w")), int(get("h"))))
      c2w.append(blender.rigid_pose(fr["transform_matrix"], path, name))
    except (TypeError, KeyError) as e:
      raise DataError(f"{path}: frame {name}: missing or bad field {e}") from None
    names.append(name)
    paths.append(os.path.join(root, fr["file_path"]))
  focal, w, h = one_pinhole(path, cams)
  points = None
  if meta.get("ply_file_path"):
    points = _read_ply_points(os.path.join(root, meta["ply_file_path"]))
  return Capture(tuple(names), tuple(paths), np.stack(c2w), focal, w, h, points)


def _read_ply_points(path):
  """xyz [P, 3] of an ASCII or binary little-endian PLY (nerfstudio's
  sparse_pc.ply: float x, y, z first, then uchar colours)."""
  with open(path, "rb") as f:
    header = []
    while not header or header[-1] != "end_header":
      header.append(f.readline().decode("ascii", "replace").strip())
    n = next(int(h.split()[2]) for h in header if h.startswith("element vertex"))
    props = [h.split() for h in header if h.startswith("property")]
    if "ascii" in header[1]:
      return np.loadtxt(f, max_rows=n, usecols=(0, 1, 2)).reshape(-1, 3)
    types = {"float": "<f4", "double": "<f8", "uchar": "u1", "uint8": "u1", "int": "<i4"}
    dtype = np.dtype([(p[2], types[p[1]]) for p in props])
    v = np.frombuffer(f.read(n * dtype.itemsize), dtype)
    return np.stack([v["x"], v["y"], v["z"]], -1).astype(np.float64)


