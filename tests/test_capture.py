"""Your own photos: structure-from-motion recovers known cameras, COLMAP
models round-trip through pycolmap's writer, transforms.json reads, and a
short HALO run trains on recovered cameras."""
import json
import os
import shutil

import numpy as np
import pytest

pycolmap = pytest.importorskip("pycolmap")

from conftest import assert_beats_constant_heldout, assert_trained  # noqa: E402
from halo_jax import configure, datasets  # noqa: E402
from halo_jax.datasets import capture, procedural  # noqa: E402
from conftest import editable  # pylint: disable=g-import-not-at-top
from halo_jax.configure import finish  # pylint: disable=g-import-not-at-top

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def similarity(src, dst):
  """Umeyama's least-squares s, R, t with dst ~ s R src + t (points [N, 3])."""
  mu_s, mu_d = src.mean(0), dst.mean(0)
  a, b = src - mu_s, dst - mu_d
  u, sig, vt = np.linalg.svd(b.T @ a / len(src))
  d = np.diag([1.0, 1.0, np.sign(np.linalg.det(u @ vt))])
  rot = u @ d @ vt
  scale = np.trace(np.diag(sig) @ d) / (a ** 2).sum(1).mean()
  return scale, rot, mu_d - scale * rot @ mu_s


def rotation_degrees(a, b):
  """The angle of the rotation a b^T, degrees."""
  cos = (np.trace(a @ b.T) - 1) / 2
  return float(np.rad2deg(np.arccos(np.clip(cos, -1.0, 1.0))))


@pytest.fixture(scope="module")
def photo_folder(tmp_path_factory):
  """A folder holding only the photos of the textured procedural scene (30
  cameras all round, 200x200), and the true camera-to-world of each."""
  scene = procedural.generate(str(tmp_path_factory.mktemp("textured")), size=200,
                              num_train=30, num_test=2, num_val=1, scene="textured")
  photos = tmp_path_factory.mktemp("photos")
  os.makedirs(photos / "images")
  with open(os.path.join(scene, "transforms_train.json")) as f:
    frames = json.load(f)["frames"]
  truth = {}
  for fr in frames:
    name = os.path.basename(fr["file_path"])
    shutil.copy(os.path.join(scene, fr["file_path"] + ".png"), photos / "images" / (name + ".png"))
    truth[name] = np.asarray(fr["transform_matrix"])
  return str(photos), truth, scene


def test_sfm_recovers_the_true_cameras_up_to_a_similarity(photo_folder):
  root, truth, _ = photo_folder
  cap = capture.read(root)
  assert os.path.isdir(os.path.join(root, "sparse", "0"))  # cached for the next launch
  assert len(cap.names) >= 25, f"only {len(cap.names)} of 30 cameras registered"
  true = np.stack([truth[n] for n in cap.names])
  s, rot, t = similarity(cap.c2w[:, :3, 3], true[:, :3, 3])
  centres = s * cap.c2w[:, :3, 3] @ rot.T + t
  err = np.linalg.norm(centres - true[:, :3, 3], axis=-1)
  assert err.max() < 0.02 * procedural.RADIUS, err.max()
  worst = max(rotation_degrees(rot @ r, q) for r, q in zip(cap.c2w[:, :3, :3], true[:, :3, :3]))
  assert worst < 1.0, worst
  focal = 0.5 * 200 / np.tan(0.5 * procedural.CAMERA_ANGLE_X)
  assert abs(cap.focal - focal) < 0.01 * focal


def test_the_loader_normalises_and_splits_by_farthest_cameras(photo_folder):
  root, _, _ = photo_folder
  from configs import capture as capture_cfg
  c = editable(capture_cfg.get_config("6view_cpu"), "halo")
  c.data.root = root
  ds = datasets.load(c.data)
  assert len(ds.train.names) == 6 and not set(ds.train.names) & set(ds.test.names)
  # all cameras at the radius on average; the training ones near it
  c2w, _, _, _, _ = capture.to_sphere(capture.read(root))
  assert abs(np.linalg.norm(c2w[:, :3, 3], axis=-1).mean() - capture.RADIUS) < 1e-6
  assert abs(ds.radius - capture.RADIUS) < 0.05 * capture.RADIUS
  # the object sits at the origin, inside [near, far] of every camera
  assert 0.5 < ds.near < capture.RADIUS - 1.0 < capture.RADIUS + 1.0 < ds.far < 3 * capture.RADIUS
  assert ds.facts.pair_kind == "orbit" and ds.train.images.shape[1:3] == ds.test.images.shape[1:3]
  c.data.kind = "capture_ff"
  with pytest.raises(datasets.DataError, match="not a forward-facing capture"):
    datasets.load(c.data)


def test_farthest_cameras_spread_out_deterministically():
  angles = np.linspace(0, 2 * np.pi, 12, endpoint=False)
  centres = np.stack([np.cos(angles), np.sin(angles), np.zeros(12)], -1)
  assert capture.farthest_cameras(centres, 2) == [0, 6]
  assert capture.farthest_cameras(centres, 4) == [0, 3, 6, 9]
  with pytest.raises(datasets.DataError, match="has 12 cameras"):
    capture.farthest_cameras(centres, 13)


def _write_model(folder, model_name, params, poses, names, text):
  """A COLMAP model of one camera written by pycolmap's own writer."""
  rec = pycolmap.Reconstruction()
  cam = pycolmap.Camera.create_from_model_name(1, model_name, 50.0, 64, 48)
  cam.params = params
  rec.add_camera_with_trivial_rig(cam)
  for i, (pose, name) in enumerate(zip(poses, names), start=1):
    image = pycolmap.Image(name=name, camera_id=1, image_id=i)
    rec.add_image_with_trivial_frame(image, pycolmap.Rigid3d(pose[:3, :4]))
  os.makedirs(folder, exist_ok=True)
  rec.write_text(folder) if text else rec.write_binary(folder)


@pytest.mark.parametrize("model_name, params", [
    ("SIMPLE_PINHOLE", [50.0, 32.0, 24.0]),
    ("PINHOLE", [50.0, 50.0, 32.0, 24.0]),
    ("SIMPLE_RADIAL", [50.0, 32.0, 24.0, 0.0]),
    ("OPENCV", [50.0, 50.0, 32.0, 24.0, 0.0, 0.0, 0.0, 0.0]),
])
@pytest.mark.parametrize("text", [False, True])
def test_colmap_models_round_trip_through_pycolmap(tmp_path, model_name, params, text):
  rng = np.random.default_rng(0)
  names = [f"im{i}.png" for i in range(3)]
  os.makedirs(tmp_path / "images")
  for n in names:
    from imageio import v3 as iio  # pylint: disable=g-import-not-at-top
    iio.imwrite(tmp_path / "images" / n, rng.integers(0, 255, (48, 64, 3), dtype=np.uint8))
  poses = []
  for i in range(3):  # world-to-camera, OpenCV axes
    q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    q *= np.sign(np.linalg.det(q))
    poses.append(np.concatenate([q, rng.normal(size=(3, 1))], 1))
  _write_model(str(tmp_path / "sparse" / "0"), model_name, params, poses, names, text)
  cap = capture.read(str(tmp_path))
  assert cap.names == ("im0", "im1", "im2") and cap.focal == pytest.approx(50.0, rel=1e-3)
  flip = np.diag([1.0, -1.0, -1.0])  # OpenCV camera axes -> OpenGL
  for c2w, w2c in zip(cap.c2w, poses):
    np.testing.assert_allclose(c2w[:3, :3], w2c[:, :3].T @ flip, atol=1e-6)
    np.testing.assert_allclose(c2w[:3, 3], -w2c[:, :3].T @ w2c[:, 3], atol=1e-6)


def test_an_off_centre_camera_is_refused_with_its_model(tmp_path):
  poses = [np.eye(4)[:3], np.eye(4)[:3] + np.array([[0, 0, 0, 1.0]] * 3)]
  os.makedirs(tmp_path / "images")
  for n in ("a.png", "b.png"):
    (tmp_path / "images" / n).write_bytes(b"")  # never read: the camera is refused first
  _write_model(str(tmp_path / "sparse" / "0"), "PINHOLE", [50.0, 50.0, 20.0, 24.0], poses,
               ["a.png", "b.png"], text=False)
  with pytest.raises(datasets.DataError, match="PINHOLE .* principal point"):
    capture.read(str(tmp_path))


def test_transforms_json_reads_poses_and_refuses_distortion(tmp_path, photo_folder):
  _, _, scene = photo_folder
  with open(os.path.join(scene, "transforms_train.json")) as f:
    frames = json.load(f)["frames"][:4]
  focal = 0.5 * 200 / np.tan(0.5 * procedural.CAMERA_ANGLE_X)
  meta = {"camera_model": "OPENCV", "fl_x": focal, "fl_y": focal, "cx": 100.0, "cy": 100.0,
          "w": 200, "h": 200,
          "frames": [{"file_path": os.path.join(scene, fr["file_path"] + ".png"),
                      "transform_matrix": fr["transform_matrix"]} for fr in frames]}
  (tmp_path / "transforms.json").write_text(json.dumps(meta))
  cap = capture.read(str(tmp_path))
  np.testing.assert_allclose(cap.c2w, [fr["transform_matrix"] for fr in frames], atol=1e-6)
  assert cap.focal == pytest.approx(focal) and cap.points is None
  meta["k1"] = 0.1
  (tmp_path / "transforms.json").write_text(json.dumps(meta))
  with pytest.raises(datasets.DataError, match="camera_model 'OPENCV' with distortion"):
    capture.read(str(tmp_path))


@pytest.mark.slow
def test_a_short_halo_run_trains_on_recovered_cameras(photo_folder, tmp_path):
  from configs import capture as capture_cfg
  from halo_jax import pipeline
  root, _, _ = photo_folder
  c = editable(capture_cfg.get_config("6view"), "halo")
  c.data.update(root=root, factor=2, test_views="every:8")
  c.eval.update(chunk=1024, lpips=False, save_images=False)
  for name in ("lo", "hi"):
    c[name].model.update(width=32, depth=2, skips=())
    c[name].sampler.update(num_samples=16)
    c[name].update(batch_rays=256, steps=100, log_every=10, precrop_steps=0, lr_init=5e-3,
                   lr_final=5e-3)
  c.ray.model.update(width=32, depth=2, skips=())
  c.ray.update(batch_rays=256, steps=40, bank_rays=1024)
  c.hi.empty.update(num_rays=64, num_samples=8, bank_rays=1024)
  infos = pipeline.run(finish(c), str(tmp_path / "run"))
  for name in ("lo", "hi"):
    assert_trained(str(tmp_path / "run"), name, c)
  assert_beats_constant_heldout(infos["hi"], "hi")
