"""Camera paths for every scene kind, path files, and the render command's videos."""
import json
import os
import re

import imageio.v3 as iio
import numpy as np
import pytest

from halo_jax import camera, camera_paths, pipeline, video
from halo_jax.configure import finish
from halo_jax.datasets import base
from halo_jax.datasets.base import DataError, Dataset, Views
from halo_jax.datasets.llff import NDCViews
from halo_jax.datasets.stanford_lf import LightFieldViews
from halo_jax.geometry import Geometry
from halo_jax.cli import render as render_cli
from conftest import pipeline_config


def _sphere_dataset(dynamic=False):
  c2w = np.stack([camera.spherical_camera(4.0, az, 30.0) for az in (0, 90, 180)])
  times = np.array([0.0, 0.5, 1.0], np.float32) if dynamic else None
  v = Views(np.zeros((3, 8, 10, 3), np.float32), c2w.astype(np.float32), 12.0,
            ("a", "b", "c"), times)
  return Dataset(v, v, 2.0, 6.0, 4.0, True, Geometry.SPHERE,
                 facts=base.ORBIT_TIME if dynamic else base.ORBIT)


def test_orbit_first_and_last_poses():
  views = camera_paths.views_for("orbit", _sphere_dataset(), 12)
  expect = camera.orbit_path(4.0, 12, 30.0)
  assert views.c2w.shape == (12, 4, 4) and views.times is None
  np.testing.assert_allclose(views.c2w[0], expect[0], atol=1e-5)
  np.testing.assert_allclose(views.c2w[-1], camera.spherical_camera(4.0, 330.0, 30.0), atol=1e-5)
  o, d = views.rays()
  assert o.shape == (12, 8, 10, 3)
  half = camera_paths.views_for("orbit", _sphere_dataset(), 12, downscale=2)
  assert half.images.shape == (12, 4, 5, 3) and half.focal == 6.0
  # the same field of view: a corner pixel's ray direction barely moves
  np.testing.assert_allclose(half.rays()[1][0, 0, 0], d[0, 0, 0], atol=0.1)


def test_dynamic_paths_run_time_from_0_to_1():
  ds = _sphere_dataset(dynamic=True)
  assert ds.facts.path_kinds[0] == "orbit_time"
  sweep = camera_paths.views_for("time", ds, 5)
  np.testing.assert_allclose(sweep.times, [0, 0.25, 0.5, 0.75, 1.0])
  assert np.all(sweep.c2w == ds.test.c2w[0])
  orbit = camera_paths.views_for("orbit_time", ds, 5)
  assert orbit.times[0] == 0.0 and orbit.times[-1] == 1.0
  assert not np.allclose(orbit.c2w[0], orbit.c2w[1])
  assert sweep.ray_times().shape == (5, 8, 10, 1)


def test_spiral_starts_at_its_radius_and_stays_orthonormal():
  rng = np.random.default_rng(0)
  c2w = np.tile(np.eye(4, dtype=np.float32), (6, 1, 1))
  c2w[:, :3, 3] = rng.normal(0, 0.1, (6, 3))
  c2w[:, :3, 3] -= c2w[:, :3, 3].mean(0)
  bounds = np.array([[1.3, 8.0]] * 6)
  poses = camera_paths.spiral(c2w, bounds, 8)
  radii = np.percentile(np.abs(c2w[:, :3, 3]), 90, axis=0)
  # theta = 0: offset (r_x, 0, 0) along the mean pose's x axis (identity here)
  np.testing.assert_allclose(poses[0, :3, 3], [radii[0], 0, 0], atol=1e-5)
  rot = poses[:, :3, :3]
  np.testing.assert_allclose(rot @ rot.transpose(0, 2, 1), np.broadcast_to(np.eye(3), rot.shape),
                             atol=1e-5)
  assert np.all(poses[:, 2, 2] > 0.9)  # still looking down -z, as the cameras do
  ds = Dataset(NDCViews(np.zeros((6, 8, 10, 3), np.float32), c2w, 12.0, tuple("abcdef")),
               NDCViews(np.zeros((6, 8, 10, 3), np.float32), c2w, 12.0, tuple("abcdef")),
               0.0, 1.0, 0.0, False, Geometry.NDC, depth_bounds=bounds, facts=base.SPIRAL)
  views = camera_paths.views_for("spiral", ds, 8)
  assert isinstance(views, NDCViews) and views.rays()[0].shape == (8, 8, 10, 3)


def test_uv_ellipse_through_the_training_offsets():
  uv = np.array([[-0.5, -0.5], [0.5, -0.5], [-0.5, 0.5], [0.5, 0.5]], np.float32)
  lf = LightFieldViews(np.zeros((4, 8, 10, 3), np.float32), uv, ("a", "b", "c", "d"))
  ds = Dataset(lf, lf, -0.1, 0.1, 0.0, False, Geometry.TWO_PLANE, facts=base.UV_PLANE)
  views = camera_paths.views_for("uv", ds, 4)
  np.testing.assert_allclose(views.uv, [[0.5, 0], [0, 0.5], [-0.5, 0], [0, -0.5]], atol=1e-6)
  with pytest.raises(DataError, match=r"--path='orbit': this scene \(two_plane rays\) takes"):
    camera_paths.views_for("orbit", ds, 4)


def test_path_files(tmp_path):
  ds = _sphere_dataset(dynamic=True)
  poses = camera.orbit_path(4.0, 3, 10.0)
  np.save(tmp_path / "p.npy", poses[:, :3, :4])
  views = camera_paths.views_for(str(tmp_path / "p.npy"), ds, 99)
  np.testing.assert_allclose(views.c2w, poses, atol=1e-6)
  assert np.all(views.times == 0)  # a static path through a dynamic scene: t = 0
  frames = [{"transform_matrix": p.tolist(), "time": t} for p, t in zip(poses, (0.1, 0.2, 0.3))]
  (tmp_path / "p.json").write_text(json.dumps({"frames": frames}))
  views = camera_paths.views_for(str(tmp_path / "p.json"), ds, 99)
  np.testing.assert_allclose(views.times, [0.1, 0.2, 0.3])
  np.save(tmp_path / "bad.npy", np.zeros((3, 2, 2)))
  with pytest.raises(DataError, match=r"bad.npy: shape \(3, 2, 2\)"):
    camera_paths.views_for(str(tmp_path / "bad.npy"), ds, 3)


def test_render_command_writes_three_videos(scene_root, tmp_path, capsys):
  wd = str(tmp_path / "run")
  pipeline.run(finish(pipeline_config(scene_root, steps=2)), wd)
  capsys.readouterr()
  w = render_cli.render_path(wd, frames=6, fps=5)
  # a bar counts the frames and ends with the rays/s rendered
  err = capsys.readouterr().err.replace("\r", "\n").splitlines()
  last = [l for l in err if l.startswith("render hi orbit")][-1]
  assert "| 6/6 [" in last and re.search(r"[0-9.e+k]+ rays/s\]$", last), last
  ext = ".mp4" if video.has_ffmpeg() else ".gif"
  for key in ("color", "depth", "acc"):
    assert w[key].endswith(f"hi_orbit_{key}{ext}")
    frames = iio.imread(w[key])
    assert frames.shape[0] == 6 and frames.shape[-1] == 3
  assert os.path.exists(os.path.join(wd, "render", "hi_orbit_color_frame0.png"))
