"""Dataset loaders, one registry entry per `data.kind`; `load(data_config,
workdir)` picks one. Each entry says its ray geometry (halo_jax.geometry) and
whether its frames carry times, so a config can be checked before any data
is read."""
import dataclasses
import os
from typing import Callable, Mapping

import ml_collections

from halo_jax import registry
from halo_jax.datasets import blender, capture, dnerf, llff, llff_planes, procedural, stanford_lf
from halo_jax.datasets.base import (ORBIT, ORBIT_TIME, SPIRAL, UV_PLANE, DataError, Dataset,
                                    SceneFacts, Views, camera_radius, spread_views, view_names)
from halo_jax.geometry import Geometry


@dataclasses.dataclass(frozen=True)
class DatasetSpec:
  """load: (data config, workdir) -> Dataset; geometry of its rays; facts:
  what its rays mean (base.SceneFacts); dynamic: its frames carry capture
  times; forms: {name: DatasetSpec} of the other ray forms the same files can
  be read in (`data.rays`; a method chooses one, the scene's kind stays)."""
  load: Callable
  geometry: Geometry
  facts: SceneFacts
  dynamic: bool = False
  forms: Mapping[str, "DatasetSpec"] = dataclasses.field(default_factory=dict)


LOADERS = registry.Registry[DatasetSpec]("dataset")


def _root(cfg, example):
  """cfg.root, or a DataError that says where a dataset is looked for."""
  if not cfg.root:
    raise DataError(f"data.root is empty: pass --config.data.root={example}")
  if not os.path.exists(cfg.root):
    raise DataError(f"data.root={cfg.root!r} does not exist: set HALO_DATA to the folder that "
                    f"holds the datasets (README, Data) or pass --config.data.root={example}")
  return cfg.root


def _load_light_field(cfg, workdir="") -> Dataset:
  """A two-plane light field: near / far are the EPI angle bounds theta_n, theta_f."""
  root = _root(cfg, "/path/to/stanford_lf/<scene>")
  signs = tuple(cfg.grid_signs)
  train = stanford_lf.load_views(root, stanford_lf.names_of(cfg.train_views, root),
                                 cfg.factor, signs)
  test = stanford_lf.load_views(root, stanford_lf.names_of(cfg.test_views, root),
                                cfg.factor, signs)
  if test.images.shape[1:] != train.images.shape[1:]:
    raise DataError(f"{root}: test and train views differ in size")
  _, (_, cols) = stanford_lf.scan(root)
  theta_n, theta_f = stanford_lf.theta_bounds(cfg.disparity_px, train.width * cfg.factor, cols)
  return Dataset(train, test, theta_n, theta_f, 0.0, False, Geometry.TWO_PLANE)


def _load_llff(cfg, workdir="") -> Dataset:
  """A forward-facing LLFF scene in NDC: near 0, far 1 (t along NDC rays)."""
  root = _root(cfg, "/path/to/nerf_llff_data/<scene>")
  names = llff.split_names(root, cfg.factor)
  train = llff.load_views(root, cfg.factor, view_names(cfg.train_views, names) or names)
  test = llff.load_views(root, cfg.factor, view_names(cfg.test_views, names) or names)
  return Dataset(train, test, 0.0, 1.0, 0.0, bool(cfg.white_background), Geometry.NDC,
                 depth_bounds=llff.read_poses(root)[3])


def _load_llff_planes(cfg, workdir="") -> Dataset:
  """An LLFF scene as a two-plane light field (llff_planes): near / far are
  distances from the (u, v) plane, the (s, t) plane at far."""
  root = _root(cfg, "/path/to/nerf_llff_data/<scene>")
  names = llff.split_names(root, cfg.factor)
  slab, near, far = llff_planes.slab_of(root)
  train = llff_planes.load_views(root, cfg.factor, view_names(cfg.train_views, names) or names,
                                 slab)
  test = llff_planes.load_views(root, cfg.factor, view_names(cfg.test_views, names) or names,
                                slab)
  return Dataset(train, test, near, far, 0.0, bool(cfg.white_background), Geometry.TWO_PLANE,
                 depth_bounds=llff.read_poses(root)[3], epi_slope="depth")


def _blender_split_names(root, split):
  _, meta = blender._read_transforms(root, split)  # pylint: disable=protected-access
  return [blender.view_name(fr["file_path"]) for fr in meta["frames"]]


def _load_posed(cfg, root, module, split_names) -> Dataset:
  """Blender-layout scenes (static or with times): cameras around the object."""
  train_names = view_names(cfg.train_views, split_names(root, "train"))
  test_names = view_names(cfg.test_views, split_names(root, cfg.test_split))
  white = bool(cfg.white_background)
  train = module.load_views(root, "train", cfg.factor, train_names, white)
  test = module.load_views(root, cfg.test_split, cfg.factor, test_names, white)
  if test.images.shape[1:] != train.images.shape[1:]:
    raise DataError(f"{root}: test images are {test.images.shape[2]}x{test.images.shape[1]}, "
                    f"train images {train.images.shape[2]}x{train.images.shape[1]}")
  return Dataset(train, test, float(cfg.near), float(cfg.far), camera_radius(train.c2w), white,
                 Geometry.SPHERE)


def _load_blender(cfg, workdir=""):
  return _load_posed(cfg, _root(cfg, "/path/to/nerf_synthetic/<scene>"), blender,
                     _blender_split_names)


def _load_dnerf(cfg, workdir=""):
  return _load_posed(cfg, _root(cfg, "/path/to/dnerf/<scene>"), dnerf, dnerf.split_names)


def _load_procedural(cfg, workdir=""):
  """A built-in scene (procedural.SCENES[data.procedural_scene]); with an
  empty data.root it is generated into `<workdir>/scene_<name>` (or a
  temporary folder), so the default job needs no data."""
  name = cfg.procedural_scene
  root = cfg.root or os.path.join(workdir or "/tmp/halo_jax", f"scene_{name}")
  procedural.generate(root, size=cfg.procedural_size, scene=name)
  return _load_posed(cfg, root, blender, _blender_split_names)


LOADERS.register("blender", DatasetSpec(_load_blender, Geometry.SPHERE, ORBIT))
LOADERS.register("procedural", DatasetSpec(_load_procedural, Geometry.SPHERE, ORBIT))
LOADERS.register("dnerf", DatasetSpec(_load_dnerf, Geometry.SPHERE, ORBIT_TIME, dynamic=True))
LOADERS.register("stanford_lf", DatasetSpec(_load_light_field, Geometry.TWO_PLANE, UV_PLANE))
# LLFF photos cut by two planes (the authors' LLFF light field): NeRF's spiral
# for videos; no view pairs, since the frequency rule tunes a Lo-NeRF this
# method does not have. LLFF's form 'planes' (data.rays, methods/halo_authors.py),
# and a kind of its own for configs made before forms.
LLFF_PLANES = DatasetSpec(_load_llff_planes, Geometry.TWO_PLANE, SceneFacts(
    "", ("spiral",), "depth fraction tau in [0, 1] between the near and far planes"))
LOADERS.register("llff", DatasetSpec(_load_llff, Geometry.NDC, SPIRAL,
                                     forms={"planes": LLFF_PLANES}))
LOADERS.register("llff_planes", LLFF_PLANES)
# your own photos (datasets/capture.py): 360-degree, and forward-facing in NDC
LOADERS.register("capture", DatasetSpec(capture.load_sphere, Geometry.SPHERE, ORBIT))
LOADERS.register("capture_ff", DatasetSpec(capture.load_forward, Geometry.NDC, SPIRAL))


def spec_of(data_cfg) -> DatasetSpec:
  """The registry entry of `data.kind`, in the form `data.rays` names where
  it names one (ConfigError naming the field)."""
  spec = LOADERS.get(data_cfg.kind, "data.kind")
  form = data_cfg.get("rays", "")
  if form and form not in spec.forms:
    raise registry.ConfigError(f"data.rays={form!r}: data.kind={data_cfg.kind!r} reads its files "
                               f"as {sorted(spec.forms) or 'its own rays only'} ('' for its own)")
  return spec.forms[form] if form else spec


def scene_kind(data_cfg) -> str:
  """'sphere', 'ndc', 'two_plane' (the geometry of `data.kind`'s rays) or
  'dynamic' (a scene in time): the kind a method's recipe is chosen by."""
  spec = spec_of(data_cfg)
  return "dynamic" if spec.dynamic else spec.geometry.value


def load(cfg, workdir: str = "") -> Dataset:
  """Loads the scene `cfg.kind` (a LOADERS entry) as the data config describes."""
  spec = spec_of(cfg)
  ds = dataclasses.replace(spec.load(cfg, workdir), facts=spec.facts)
  if not cfg.get("select_views"):
    return ds
  # the selection views load as another split's test views of the same scene
  other = ml_collections.ConfigDict(cfg.to_dict())
  other.update(test_split=cfg.select_split, test_views=cfg.select_views)
  select = spec.load(other, workdir).test
  # never choose on a test view: the same image in both sets is refused
  test = {v.tobytes() for v in ds.test.images}
  shared = [n for n, v in zip(select.names, select.images) if v.tobytes() in test]
  if shared:
    raise DataError(f"data.select_views={cfg.select_views!r} (split {cfg.select_split!r}) "
                    f"holds test views {shared}: model selection never sees a test view")
  return dataclasses.replace(ds, select=select)


__all__ = ["DataError", "Dataset", "DatasetSpec", "LOADERS", "SceneFacts", "Views", "load", "spread_views",
           "spec_of",
           "blender", "capture", "dnerf", "llff", "llff_planes", "procedural", "stanford_lf"]
