"""HALO behind nerfbaselines' Method interface (halo_jax/integrations).

The fast tests build nerfbaselines' data by hand, as its Blender loader does
(OpenCV poses, RGBA uint8 images, intrinsics from camera_angle_x), and check
that the scene, its cameras and its rays come out as our own loader makes
them. The slow ones train through the interface, and run nerfbaselines
itself in a virtual environment of its own (skipped when one cannot be made).
"""
import dataclasses
import json
import os
import subprocess
import sys

import imageio.v2 as imageio
import jax
import numpy as np
import pytest

from conftest import pipeline_config, tiny_config
from halo_jax import camera, datasets, pipeline, restore
from halo_jax.datasets import capture
from halo_jax.integrations import nerfbaselines_method as nbm
from halo_jax.integrations import nerfbaselines_scene as nbs
from halo_jax.stages import pacing
from halo_jax.configure import finish  # pylint: disable=g-import-not-at-top

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
NAMES = ["r_0", "r_13", "r_26", "r_39"]


@dataclasses.dataclass
class Cameras:
  """nerfbaselines' Cameras fields, as numpy arrays."""
  poses: np.ndarray
  intrinsics: np.ndarray
  camera_models: np.ndarray
  image_sizes: np.ndarray
  nears_fars: np.ndarray

  def __getitem__(self, i):
    return Cameras(*(getattr(self, f.name)[i] for f in dataclasses.fields(self)))

  def item(self):
    return self


def nb_blender(root, names):
  """A nerfbaselines training dataset of a Blender-layout scene, read the way
  nerfbaselines' blender loader reads it (not through our loader)."""
  with open(os.path.join(root, "transforms_train.json")) as f:
    meta = json.load(f)
  frames = {os.path.basename(fr["file_path"]): fr for fr in meta["frames"]}
  images = [imageio.imread(os.path.join(root, frames[n]["file_path"] + ".png")) for n in names]
  h, w = images[0].shape[:2]
  poses = np.stack([np.array(frames[n]["transform_matrix"])[:3] for n in names])
  poses[..., 1:3] *= -1  # OpenGL -> OpenCV
  f = 0.5 * w / np.tan(0.5 * meta["camera_angle_x"])
  k = len(names)
  cams = Cameras(poses, np.tile([f, f, w / 2, h / 2], (k, 1)), np.zeros(k, np.int32),
                 np.tile([w, h], (k, 1)), np.tile([2.0, 6.0], (k, 1)))
  return {"images": images, "cameras": cams,
          "metadata": {"background_color": np.array([255, 255, 255], np.uint8),
                       "color_space": "srgb"}}


def test_the_blender_layout_comes_out_as_our_loader_makes_it(scene_root):
  scene = nbs.to_scene(nb_blender(scene_root, NAMES))
  c = tiny_config()
  c.data.update(root=scene_root, factor=1, train_views=",".join(NAMES))
  ours = datasets.load(c.data)
  assert scene.kind == "object"
  np.testing.assert_allclose(scene.dataset.train.images, ours.train.images, atol=1e-6)
  np.testing.assert_allclose(scene.dataset.train.c2w, ours.train.c2w, atol=1e-6)
  assert scene.dataset.train.focal == pytest.approx(ours.train.focal)
  assert (scene.dataset.near, scene.dataset.far) == (2.0, 6.0)


def test_a_harness_camera_gives_the_rays_of_its_view_in_every_frame(scene_root):
  nb = nb_blender(scene_root, NAMES)
  for kind in ("object", "capture"):
    scene = nbs.to_scene(nb, kind)
    o, d = scene.dataset.train.rays()
    for i in range(len(NAMES)):
      cam = nb["cameras"][i]
      co, cd = nbs.camera_rays(scene, cam.poses, cam.intrinsics, cam.image_sizes)
      np.testing.assert_allclose(co, o[i], atol=1e-5)
      np.testing.assert_allclose(cd, d[i], atol=1e-5)
  # the capture frame is the one capture.py gives the same cameras
  frame = capture.sphere_frame(camera.opencv_to_opengl(nb["cameras"].poses))
  np.testing.assert_allclose(scene.frame.scale, frame.scale)
  centres = np.linalg.norm(scene.dataset.train.c2w[:, :3, 3], axis=-1)
  assert centres.mean() == pytest.approx(capture.RADIUS, rel=1e-5)


def test_an_off_centre_principal_point_is_refused_with_one_line(scene_root):
  nb = nb_blender(scene_root, NAMES)
  nb["cameras"].intrinsics[1, 2] += 5.0
  with pytest.raises(datasets.DataError, match="principal point"):
    nbs.to_scene(nb)


def test_set_values_are_read_as_the_types_they_spell():
  assert [nbm.parse_value(v) for v in ("30", "1e-3", "true", "False", "halo", 7)] == \
      [30, 1e-3, True, False, "halo", 7]
  with pytest.raises(Exception, match="no field 'lo.nope'"):
    nbm.make_config("object", {"config": tiny_config(), "lo.nope": "1"})


@pytest.mark.slow
def test_a_paced_run_is_the_run(scene_root, tmp_path):
  """Stepped one step at a time from another thread, the pipeline ends with
  the parameters of the same run left to itself."""
  c = pipeline_config(scene_root, steps=3)
  pipeline.run(finish(c), str(tmp_path / "free"))
  paced = pacing.Paced(lambda p: pipeline.run(finish(c), str(tmp_path / "paced"), None, p))
  records = []
  while (r := paced.step()) is not None:
    records.append((r.stage, r.step))
  paced.join()
  assert records == [(n, s) for n in ("lo", "ray", "hi") for s in (1, 2, 3)]
  free, other = (restore.load(str(tmp_path / w), "hi").states["hi"] for w in ("free", "paced"))
  for a, b in zip(jax.tree_util.tree_leaves(free.params), jax.tree_util.tree_leaves(other.params)):
    np.testing.assert_array_equal(np.asarray(a), np.asarray(b))


def _method(nb, tmp_path=None, checkpoint=None):
  c = pipeline_config("", steps=3)
  return nbm.HaloMethod(train_dataset=nb, checkpoint=checkpoint,
                        config_overrides={"config": c, "scene_kind": "object"})


@pytest.mark.slow
def test_train_iterations_save_resume_and_render(scene_root, tmp_path):
  nb = nb_blender(scene_root, NAMES)
  whole = _method(nb)
  assert whole.get_info()["num_iterations"] == 9
  metrics = [whole.train_iteration(i) for i in range(9)]
  assert all(np.isfinite(m["loss"]) for m in metrics)
  assert whole.train_iteration(9) == {}
  whole.save(str(tmp_path / "end"))
  # stopped after 4 iterations (in the ray field), saved, resumed to the end
  part = _method(nb)
  for i in range(4):
    part.train_iteration(i)
  part.save(str(tmp_path / "mid"))
  resumed = _method(nb, checkpoint=str(tmp_path / "mid"))
  assert resumed.get_info()["loaded_step"] == 4
  for i in range(4, 9):
    resumed.train_iteration(i)
  resumed.save(str(tmp_path / "resumed"))
  cam = nb["cameras"][1]
  a = nbm.HaloMethod(checkpoint=str(tmp_path / "end")).render(cam)
  b = nbm.HaloMethod(checkpoint=str(tmp_path / "resumed")).render(cam)
  assert a["color"].shape == (64, 64, 3) and a["depth"].shape == (64, 64)
  np.testing.assert_array_equal(a["color"], b["color"])
  np.testing.assert_allclose(a["color"], whole.render(cam)["color"], atol=1e-6)


# nerfbaselines itself, in a venv of its own (it pins numpy below 2).
def _nerfbaselines_venv(folder):
  """The venv's python, or None when it cannot be made (no network, say)."""
  python = os.path.join(folder, "bin", "python")
  if os.path.exists(python):
    return python
  made = subprocess.run([sys.executable, "-m", "venv", folder], capture_output=True)
  if made.returncode == 0:
    made = subprocess.run([python, "-m", "pip", "install", "-q", "nerfbaselines"],
                          capture_output=True, text=True, timeout=600)
  return python if made.returncode == 0 else None


@pytest.fixture(scope="module")
def nb_python(tmp_path_factory):
  folder = os.environ.get("HALO_NERFBASELINES_VENV") or str(tmp_path_factory.mktemp("nbvenv"))
  python = _nerfbaselines_venv(folder)
  if python is None:
    pytest.skip("no venv with nerfbaselines could be made (pip install nerfbaselines failed)")
  return python


def _nerfbaselines(python, *args):
  env = dict(os.environ, HALO_JAX_PYTHON=sys.executable,
             NERFBASELINES_REGISTER=os.path.join(ROOT, "halo_jax", "integrations",
                                                 "nerfbaselines_spec.py"))
  exe = os.path.join(os.path.dirname(python), "nerfbaselines")
  return subprocess.run([exe, *args], capture_output=True, text=True, env=env, timeout=900)


@pytest.mark.slow
def test_nerfbaselines_trains_renders_and_rescores_halo(nb_python, scene_root, tmp_path):
  """`nerfbaselines train` and `render` run HALO in our environment over its
  RPC; the training views it renders are the ones our renderer draws from
  the same checkpoint; and experiments/nerfbaselines_check.py's scores of a
  halo-eval output agree with ours."""
  few = str(tmp_path / "scene")
  made = subprocess.run([nb_python, "-c", (
      f"import sys; sys.path.insert(0, {ROOT!r});"
      "from halo_jax.integrations import nerfbaselines_datasets as d;"
      f"d.write_few_shot({scene_root!r}, {few!r}, {NAMES!r}, 'lattice')")],
      capture_output=True, text=True)
  assert made.returncode == 0, made.stderr[-2000:]
  out = str(tmp_path / "out")
  sets = [a for f in ("cpu=True", "lo.steps=4", "ray.steps=4", "hi.steps=4", "lo.min_steps=0",
                      "ray.min_steps=0", "hi.min_steps=0") for a in ("--set", f)]
  run = _nerfbaselines(nb_python, "train", "--method", "halo", "--data", few, "--output", out,
                       "--backend", "python", "--eval-few-iters", "1000", "--eval-all-iters",
                       "1000", "--disable-output-artifact", "--logger", "none", *sets)
  assert run.returncode == 0, run.stderr[-3000:]
  ckpt = os.path.join(out, "checkpoint-12")
  pred = str(tmp_path / "pred")
  run = _nerfbaselines(nb_python, "render", "--checkpoint", ckpt, "--data", few, "--output",
                       pred, "--split", "train", "--backend", "python")
  assert run.returncode == 0, run.stderr[-3000:]
  method = nbm.HaloMethod(checkpoint=ckpt)
  ours = method.render_views(method.scene.dataset.train)
  for i in range(len(NAMES)):
    theirs = imageio.imread(os.path.join(pred, "color", "train", f"{NAMES[i]}.png"))[..., :3]
    theirs = theirs / 255.0
    assert np.abs(theirs - np.round(ours[i] * 255) / 255).max() <= 1.01 / 255


@pytest.mark.slow
def test_nerfbaselines_scores_a_halo_eval_output_as_we_do(nb_python, scene_root, tmp_path):
  """experiments/nerfbaselines_check.py: nerfbaselines reads halo-eval's
  output unchanged; its PSNR and SSIM agree with ours (LPIPS too where its
  backbone weights load, which needs a network)."""
  from halo_jax.cli import evaluate as evaluate_cli  # pylint: disable=g-import-not-at-top
  wd = str(tmp_path / "run")
  pipeline.run(finish(pipeline_config(scene_root, steps=2)), wd)
  out = evaluate_cli.run_evaluation(wd, with_lpips=False)["out"]
  check = str(tmp_path / "check.json")
  run = subprocess.run([nb_python, os.path.join(ROOT, "experiments", "nerfbaselines_check.py"),
                        out, check], capture_output=True, text=True, timeout=600)
  assert run.returncode == 0, run.stderr[-3000:]
  with open(check) as f:
    rows = json.load(f)["metrics"]
  assert {"psnr", "ssim"} <= set(rows)
  assert abs(rows["psnr"]["difference"]) < 1e-4 and abs(rows["ssim"]["difference"]) < 1e-4


def test_the_regnerf_split_for_nerfbaselines_is_ours():
  from halo_jax.datasets.base import spread_views  # pylint: disable=g-import-not-at-top
  from halo_jax.integrations import nerfbaselines_datasets as nbd  # pylint: disable=g-import-not-at-top
  for n in (20, 34, 62):
    names = [f"{i:03d}" for i in range(n)]
    for k in nbd.LLFF_VIEWS:
      train, test = nbd.regnerf_split(n, k)
      assert [names[i] for i in train] == spread_views(names, k, nbd.LLFF_HOLD)
      assert test == list(range(0, n, 8))


FERN = os.path.join(os.path.dirname(ROOT), "shared", "data", "nerf_llff_data", "fern")


@pytest.mark.slow
@pytest.mark.skipif(not os.path.exists(FERN), reason="needs ../shared/data (LLFF fern)")
def test_nerfbaselines_loads_fern_with_regnerfs_views(nb_python, tmp_path):
  """llff-regnerf/fern-n3 through nerfbaselines' own load_dataset: the three
  views llff.py:fern_3view trains on, at images_8's size."""
  out = str(tmp_path / "fern-n3")
  code = (f"import sys, os, json; sys.path.insert(0, {ROOT!r});"
          "from halo_jax.integrations import nerfbaselines_datasets as d;"
          f"os.environ['HALO_DATA'] = {os.path.dirname(os.path.dirname(FERN))!r};"
          f"d.download_llff_regnerf('llff-regnerf/fern-n3', {out!r});"
          "from nerfbaselines.datasets import load_dataset;"
          f"ds = load_dataset({out!r}, split='train', features=frozenset(('color',)));"
          "print(json.dumps([[os.path.basename(p) for p in ds['image_paths']],"
          " ds['cameras'].image_sizes.tolist()]))")
  run = subprocess.run([nb_python, "-c", code], capture_output=True, text=True, timeout=300)
  assert run.returncode == 0, run.stderr[-3000:]
  names, sizes = json.loads(run.stdout.strip().splitlines()[-1])
  assert names == ["image001.png", "image010.png", "image019.png"]
  assert sizes == [[504, 378]] * 3
