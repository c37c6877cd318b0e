"""Dataset loaders; `load(data_config, workdir)` picks one from the config."""
import os

from halo_jax.datasets import blender, dnerf, llff, procedural, stanford_lf
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


def _load_light_field(cfg) -> Dataset:
  """A two-plane light field: near / far are the EPI angle bounds theta_n, theta_f."""
  if not cfg.root:
    raise DataError("data.root is empty: pass --config.data.root=/path/to/stanford_lf/<scene>")
  signs = tuple(cfg.grid_signs)
  train = stanford_lf.load_views(cfg.root, stanford_lf.names_of(cfg.train_views, cfg.root),
                                 cfg.factor, signs)
  test = stanford_lf.load_views(cfg.root, stanford_lf.names_of(cfg.test_views, cfg.root),
                                cfg.factor, signs)
  if test.images.shape[1:] != train.images.shape[1:]:
    raise DataError(f"{cfg.root}: test and train views differ in size")
  _, (_, cols) = stanford_lf.scan(cfg.root)
  theta_n, theta_f = stanford_lf.theta_bounds(cfg.disparity_px, train.width * cfg.factor, cols)
  return Dataset(train, test, theta_n, theta_f, 0.0, False)


def _load_llff(cfg) -> Dataset:
  """A forward-facing LLFF scene in NDC: near 0, far 1; radius 0 tells the ray
  field that rays start on their entry plane (the NDC near plane)."""
  if not cfg.root:
    raise DataError("data.root is empty: pass --config.data.root=/path/to/nerf_llff_data/<scene>")
  names = llff.split_names(cfg.root, cfg.factor)
  train = llff.load_views(cfg.root, cfg.factor, _names(cfg.train_views, names) or names)
  test = llff.load_views(cfg.root, cfg.factor, _names(cfg.test_views, names) or names)
  return Dataset(train, test, 0.0, 1.0, 0.0, bool(cfg.white_background))


def load(cfg, workdir: str = "") -> Dataset:
  """Loads `cfg.kind` ('blender', 'procedural' or 'dnerf') as described by the data config.

  For 'procedural' with an empty `cfg.root`, the scene is generated into
  `<workdir>/scene` (or a temporary folder), so the default job needs no data.
  """
  if cfg.kind == "stanford_lf":
    return _load_light_field(cfg)
  if cfg.kind == "llff":
    return _load_llff(cfg)
  if cfg.kind == "procedural":
    root = cfg.root or os.path.join(workdir or "/tmp/halo_jax", "scene")
    procedural.generate(root, size=cfg.procedural_size)
  elif cfg.kind in ("blender", "dnerf"):
    root = cfg.root
    if not root:
      raise DataError("data.root is empty: pass --config.data.root=/path/to/the/scene")
  else:
    raise DataError(f"data.kind={cfg.kind!r} is not one of 'blender', 'procedural', 'dnerf'")
  module = dnerf if cfg.kind == "dnerf" else blender
  split_names = dnerf.split_names if cfg.kind == "dnerf" else _split_names
  train_names = _names(cfg.train_views, split_names(root, "train"))
  test_names = _names(cfg.test_views, split_names(root, cfg.test_split))
  white = bool(cfg.white_background)
  train = module.load_views(root, "train", cfg.factor, train_names, white)
  test = module.load_views(root, cfg.test_split, cfg.factor, test_names, white)
  if test.images.shape[1:] != train.images.shape[1:]:
    raise DataError(f"{root}: test images are {test.images.shape[2]}x{test.images.shape[1]}, "
                    f"train images {train.images.shape[2]}x{train.images.shape[1]}")
  return Dataset(train, test, float(cfg.near), float(cfg.far), camera_radius(train.c2w), white)


__all__ = ["DataError", "Dataset", "Views", "load", "blender", "dnerf", "llff", "procedural", "stanford_lf"]
