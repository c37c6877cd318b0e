"""D-NeRF dynamic scenes: the Blender layout with a 'time' per frame, or the
packed `tiny_dnerf_data.npz` (images, poses, times, focal).

The npz holds its splits back to back (lego: train 50, val 11, test 20); each
split's times run from 0 to 1, so a split starts wherever time goes back.
"""
import os

import numpy as np

from halo_jax.datasets import blender
from halo_jax.datasets.base import DataError, Views

NPZ_SPLITS = ("train", "val", "test")
_NPZ_FIELDS = {"images": 4, "poses": 3, "times": 1, "focal": 0}


def read_npz(path: str) -> dict:
  """{split: Views} of a packed D-NeRF file, each view named '<split>_<index>'."""
  if not os.path.exists(path):
    raise DataError(f"{path}: file not found (data.root)")
  try:
    raw = np.load(path)
  except Exception as e:  # a truncated or non-npz file raises several types
    raise DataError(f"{path}: cannot read as .npz ({e})") from e
  arrays = {}
  for name, ndim in _NPZ_FIELDS.items():
    if name not in raw:
      raise DataError(f"{path}: missing array {name!r} (has {sorted(raw.files)})")
    arrays[name] = np.asarray(raw[name])
    if arrays[name].ndim != ndim:
      raise DataError(f"{path}: array {name!r} has shape {arrays[name].shape}, "
                      f"expected {ndim} dimensions")
  images, poses, times = arrays["images"], arrays["poses"], arrays["times"]
  n = images.shape[0]
  if images.shape[-1] != 3 or poses.shape != (n, 4, 4) or times.shape != (n,):
    raise DataError(f"{path}: shapes images {images.shape}, poses {poses.shape}, times "
                    f"{times.shape} do not describe {n} RGB views with 4x4 poses")
  if not np.all(np.isfinite(poses)):
    bad = int(np.flatnonzero(~np.isfinite(poses).all((1, 2)))[0])
    raise DataError(f"{path}: 'poses'[{bad}] is not finite")
  if not (np.all(np.isfinite(times)) and times.min() >= 0 and times.max() <= 1):
    raise DataError(f"{path}: 'times' must be finite and in [0, 1]")
  focal = float(arrays["focal"])
  if not np.isfinite(focal) or focal <= 0:
    raise DataError(f"{path}: 'focal' must be a positive number, got {focal}")
  starts = [0] + [i for i in range(1, n) if times[i] < times[i - 1]] + [n]
  if len(starts) - 1 != len(NPZ_SPLITS):
    raise DataError(f"{path}: 'times' restart {len(starts) - 2} times; expected the "
                    f"{len(NPZ_SPLITS)} splits {NPZ_SPLITS} back to back")
  out = {}
  for split, a, b in zip(NPZ_SPLITS, starts[:-1], starts[1:]):
    names = tuple(f"{split}_{i:03d}" for i in range(b - a))
    out[split] = Views(images[a:b].astype(np.float32), poses[a:b].astype(np.float32), focal,
                       names, times[a:b].astype(np.float32))
  return out


def pick(views: Views, names, where: str) -> Views:
  """The named subset of `views`, in the order given."""
  if names is None:
    return views
  index = {n: i for i, n in enumerate(views.names)}
  missing = [n for n in names if n not in index]
  if missing:
    raise DataError(f"{where}: views {missing} named in the config are not in the data")
  i = np.array([index[n] for n in names])
  return Views(views.images[i], views.c2w[i], views.focal, tuple(names), views.times[i])


def split_names(root: str, split: str):
  if root.endswith(".npz"):
    return read_npz(root)[split].names
  _, meta = blender._read_transforms(root, split)
  return [blender.view_name(fr["file_path"]) for fr in meta["frames"]]


def load_views(root: str, split: str, factor: int, names, white_background: bool) -> Views:
  """One split of a D-NeRF scene (folder or .npz); every frame must carry a time."""
  if root.endswith(".npz"):
    if factor != 1:
      raise DataError(f"{root}: data.factor={factor}; the packed file is used at its "
                      "own size (factor 1)")
    return pick(read_npz(root)[split], names, root)
  views = blender.load_views(root, split, factor, names, white_background)
  if views.times is None:
    raise DataError(f"{os.path.join(root, f'transforms_{split}.json')}: frames have no "
                    "field 'time' (not a D-NeRF scene?)")
  return views
