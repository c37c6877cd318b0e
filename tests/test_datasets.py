import json
import os
import shutil

import numpy as np
import pytest

from halo_jax import configure, datasets
from halo_jax.datasets import blender, procedural
from conftest import SHARED_DATA, tiny_config
from conftest import editable  # pylint: disable=g-import-not-at-top

LEGO = os.path.join(SHARED_DATA, "nerf_synthetic", "lego")


def test_procedural_scene_is_deterministic_and_blender_layout(tmp_path, scene_root):
  root = procedural.generate(str(tmp_path / "again"), size=64)
  a = blender.load_views(scene_root, "train", 1, ["r_5"])
  b = blender.load_views(root, "train", 1, ["r_5"])
  np.testing.assert_array_equal(a.images, b.images)
  assert a.images.shape == (1, 64, 64, 3)
  assert 0.0 < a.images.mean() < 1.0


def test_procedural_ground_truth_is_analytic():
  # A ray straight down through the big sphere's top hits it at z = 0.1 + 0.75.
  rgba, depth = procedural.render_rays(np.array([[0.0, 0.0, 4.0]]), np.array([[0.0, 0.0, -1.0]]))
  np.testing.assert_allclose(depth, [4.0 - 0.85], atol=1e-12)
  assert rgba[0, 3] == 1.0
  rgba, depth = procedural.render_rays(np.array([[0.0, 0.0, 4.0]]), np.array([[0.0, 0.0, 1.0]]))
  assert rgba[0, 3] == 0.0


def test_lattice_scene_ground_truth_is_analytic():
  # Straight down at x = y = 0.2 (clear of the top bar, |y| < 0.025) onto the
  # core sphere of radius 0.4 at the origin: z = sqrt(0.4^2 - 0.08).
  rgba, depth = procedural.render_rays(np.array([[0.2, 0.2, 4.0]]),
                                       np.array([[0.0, 0.0, -1.0]]), "lattice")
  np.testing.assert_allclose(depth, [4.0 - np.sqrt(0.08)], atol=1e-12)
  # Straight down at the origin: the top bar (z up to 0.95) first.
  _, depth = procedural.render_rays(np.array([[0.0, 0.0, 4.0]]),
                                    np.array([[0.0, 0.0, -1.0]]), "lattice")
  np.testing.assert_allclose(depth, [4.0 - 0.95], atol=1e-12)
  # Horizontally at z = 0.5 towards the rod at angle 0 (centre x = 0.95, radius
  # 0.035) from x = 4: it meets the rod's side at x = 0.985.
  rgba, depth = procedural.render_rays(np.array([[4.0, 0.0, 0.5]]),
                                       np.array([[-1.0, 0.0, 0.0]]), "lattice")
  np.testing.assert_allclose(depth, [4.0 - 0.985], atol=1e-12)
  assert rgba[0, 3] == 1.0
  # Above the rods' tops (z = 0.9) and the bars, between bars: nothing.
  rgba, _ = procedural.render_rays(np.array([[4.0, 0.5, 1.2]]), np.array([[-1.0, 0.0, 0.0]]),
                                   "lattice")
  assert rgba[0, 3] == 0.0


def test_lattice_training_cameras_see_one_side(tmp_path):
  root = procedural.generate(str(tmp_path / "lat"), size=16, num_train=20, num_test=8,
                             scene="lattice")
  train = blender.load_views(root, "train", 1)
  test = blender.load_views(root, "test", 1)
  assert np.all(train.c2w[:, 0, 3] > 0)  # azimuths in (-90, 90): x > 0
  assert np.any(test.c2w[:, 0, 3] < -1)  # the orbit goes round the back


def test_load_selects_views_and_factor(scene_root):
  c = tiny_config()
  c.data.root = scene_root
  ds = datasets.load(c.data)
  assert ds.train.names == ("r_0", "r_13", "r_26", "r_39")
  assert ds.train.images.shape == (4, 32, 32, 3)
  assert ds.test.names == ("r_0", "r_100")
  np.testing.assert_allclose(ds.radius, procedural.RADIUS, rtol=1e-5)


def _copy_scene(scene_root, tmp_path):
  root = str(tmp_path / "scene")
  shutil.copytree(scene_root, root)
  return root


def test_missing_transforms_names_the_file(tmp_path):
  with pytest.raises(datasets.DataError, match="transforms_train.json: file not found"):
    blender.load_views(str(tmp_path), "train")


def test_malformed_json_names_the_file(scene_root, tmp_path):
  root = _copy_scene(scene_root, tmp_path)
  with open(os.path.join(root, "transforms_train.json"), "w") as f:
    f.write("{ not json")
  with pytest.raises(datasets.DataError, match="transforms_train.json: malformed JSON"):
    blender.load_views(root, "train")


def test_unknown_view_and_nan_pose(scene_root, tmp_path):
  with pytest.raises(datasets.DataError, match=r"views \['r_999'\]"):
    blender.load_views(scene_root, "train", 1, ["r_999"])
  root = _copy_scene(scene_root, tmp_path)
  path = os.path.join(root, "transforms_train.json")
  meta = json.load(open(path))
  meta["frames"][0]["transform_matrix"][0][3] = float("nan")
  json.dump(meta, open(path, "w"))
  with pytest.raises(datasets.DataError, match="'transform_matrix' of r_0 is not a finite"):
    blender.load_views(root, "train", 1, ["r_0"])


def test_missing_image_names_the_file(scene_root, tmp_path):
  root = _copy_scene(scene_root, tmp_path)
  os.remove(os.path.join(root, "train", "r_3.png"))
  with pytest.raises(datasets.DataError, match=r"r_3\.png: image file not found"):
    blender.load_views(root, "train", 1, ["r_3"])


@pytest.mark.skipif(not os.path.isdir(LEGO), reason="lego not in the datasets folder")
def test_lego_eight_views_factor_8():
  from configs import blender as blender_configs
  c = editable(blender_configs.get_config("lego_8view_cpu"), "halo")
  c.data.root = LEGO
  ds = datasets.load(c.data)
  assert ds.train.names == ("r_2", "r_16", "r_93", "r_55", "r_73", "r_86", "r_26", "r_75")
  assert ds.train.images.shape == (8, 100, 100, 3)
  assert ds.test.names[:3] == ("r_0", "r_8", "r_16") and len(ds.test.names) == 25
  np.testing.assert_allclose(ds.train.focal, 1111.1110311937682 / 8, rtol=1e-6)
  np.testing.assert_allclose(ds.radius, 4.031, atol=0.01)
  # RGBA on white: corners are background.
  np.testing.assert_allclose(ds.train.images[:, 0, 0], 1.0, atol=1e-6)


def test_a_ray_form_is_the_kinds_to_name():
  """data.rays picks another form a kind's files are read in (LLFF's 'planes');
  a form the kind does not have is one line naming the field."""
  import ml_collections  # pylint: disable=import-outside-toplevel
  from halo_jax import datasets, registry  # pylint: disable=import-outside-toplevel
  from halo_jax.geometry import Geometry  # pylint: disable=import-outside-toplevel
  llff = ml_collections.ConfigDict(dict(kind="llff", rays=""))
  assert datasets.spec_of(llff).geometry == Geometry.NDC
  llff.rays = "planes"
  assert datasets.spec_of(llff).geometry == Geometry.TWO_PLANE
  assert datasets.scene_kind(llff) == "two_plane"
  for kind, rays in (("llff", "sphere"), ("blender", "planes")):
    with pytest.raises(registry.ConfigError, match=f"data.rays='{rays}': data.kind='{kind}'"):
      datasets.spec_of(ml_collections.ConfigDict(dict(kind=kind, rays=rays)))
