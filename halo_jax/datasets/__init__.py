"""Dataset loaders; `load(data_config, workdir)` picks one from the config."""
import os

from halo_jax.datasets import blender, procedural
from halo_jax.datasets.base import DataError, Dataset, Views, camera_radius


def _names(spec, split_names):
  """A view list from the config: a list/tuple of names, 'all', or 'every:K'."""
  if spec in (None, "all"):
    return None
  if isinstance(spec, str) and spec.startswith("every:"):
    return list(split_names)[::int(spec.split(":")[1])]
  if isinstance(spec, str):
    return [s for s in spec.split(",") if s]
  return list(spec)


def _split_names(root, split):
  _, meta = blender._read_transforms(root, split)
  return [blender.view_name(fr["file_path"]) for fr in meta["frames"]]


def load(cfg, workdir: str = "") -> Dataset:
  """Loads `cfg.kind` ('blender' or 'procedural') as described by the data config.

  For 'procedural' with an empty `cfg.root`, the scene is generated into
  `<workdir>/scene` (or a temporary folder), so the default job needs no data.
  """
  if cfg.kind == "procedural":
    root = cfg.root or os.path.join(workdir or "/tmp/halo_jax", "scene")
    procedural.generate(root, size=cfg.procedural_size)
  elif cfg.kind == "blender":
    root = cfg.root
    if not root:
      raise DataError("data.root is empty: pass --config.data.root=/path/to/nerf_synthetic/<scene>")
  else:
    raise DataError(f"data.kind={cfg.kind!r} is not one of 'blender', 'procedural'")
  train_names = _names(cfg.train_views, _split_names(root, "train"))
  test_names = _names(cfg.test_views, _split_names(root, cfg.test_split))
  white = bool(cfg.white_background)
  train = blender.load_views(root, "train", cfg.factor, train_names, white)
  test = blender.load_views(root, cfg.test_split, cfg.factor, test_names, white)
  if test.images.shape[1:] != train.images.shape[1:]:
    raise DataError(f"{root}: test images are {test.images.shape[2]}x{test.images.shape[1]}, "
                    f"train images {train.images.shape[2]}x{train.images.shape[1]}")
  return Dataset(train, test, float(cfg.near), float(cfg.far), camera_radius(train.c2w), white)


__all__ = ["DataError", "Dataset", "Views", "load", "blender", "procedural"]
