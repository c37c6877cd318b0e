"""LLFF: NDC rays against a hand-computed case, the loader (poses, views,
bad input) and a smoke run of the forward-facing HALO stages."""
import os

import imageio.v3 as iio
import numpy as np
import pytest

from conftest import SHARED_DATA, assert_trained, tiny_config
from halo_jax import camera, configure, datasets, methods, pipeline, stages
from conftest import editable  # pylint: disable=g-import-not-at-top
from halo_jax.configure import finish  # pylint: disable=g-import-not-at-top

FERN = os.path.join(SHARED_DATA, "nerf_llff_data", "fern")


def test_ndc_against_hand_computed_ray():
  # H = W = 2, focal 1 (so -2 f / W = -1), near 1; origin (0.2, 0.1, 0.5),
  # direction (0.1, 0.2, -1). Moved to z = -1: t = 1.5, o = (0.35, 0.4, -1).
  o, d = camera.ndc_rays(np.array([0.2, 0.1, 0.5]), np.array([0.1, 0.2, -1.0]), 2, 2, 1.0)
  np.testing.assert_allclose(o, [0.35, 0.4, -1.0], atol=1e-12)
  np.testing.assert_allclose(d, [-0.25, -0.2, 2.0], atol=1e-12)
  # The world point o + 3 d = (0.5, 0.7, -2.5) projects to NDC (0.2, 0.28, 0.2),
  # which is on the NDC ray at t = 0.6.
  np.testing.assert_allclose(o + 0.6 * d, [0.2, 0.28, 0.2], atol=1e-12)


def write_llff(root, n=6, h=12, w=16, focal_full=40.0, factor=2):
  """A forward-facing rig: cameras on a small grid, all looking down -z
  (LLFF's [down, right, back] axes), and images of a colour ramp."""
  os.makedirs(os.path.join(root, f"images_{factor}"), exist_ok=True)
  rows = []
  for i in range(n):
    # camera-to-world in [down, right, back]: columns down, right, back, centre
    rot = np.array([[0, 1, 0], [-1, 0, 0], [0, 0, 1.0]])  # down=-y, right=x, back=z
    centre = np.array([0.1 * (i % 3), 0.1 * (i // 3), 0.0])
    m = np.concatenate([rot, centre[:, None], [[h * factor], [w * factor], [focal_full]]], 1)
    rows.append(np.concatenate([m.reshape(-1), [2.0, 10.0]]))
    y, x = np.mgrid[0:h, 0:w]
    img = np.stack([x / w, y / h, np.full_like(x, i / n, dtype=float)], -1)
    iio.imwrite(os.path.join(root, f"images_{factor}", f"image{i:03d}.png"),
                (img * 255).astype(np.uint8))
  np.save(os.path.join(root, "poses_bounds.npy"), np.asarray(rows))
  return root


def llff_config(root, method="halo"):
  c = tiny_config(method="")
  c.data.update(kind="llff", root=root, factor=2, train_views="000,002,003,005",
                test_views="004", near=0.0, far=1.0, white_background=False)
  for name in ("lo", "hi"):
    c[name].precrop_steps = 0
  c = methods.apply(c, method)
  c.hi.encoding.with_lo = True
  c.hi.init_from_lo = True
  return c


def test_loader_recentres_and_names_views(tmp_path):
  root = write_llff(str(tmp_path / "scene"))
  ds = datasets.load(llff_config(root).data)
  assert ds.train.names == ("000", "002", "003", "005") and ds.test.names == ("004",)
  assert ds.train.images.shape == (4, 12, 16, 3)
  assert ds.train.focal == pytest.approx(20.0)  # 40 px at full size, factor 2
  # All cameras look down -z after the axis change and recentring.
  np.testing.assert_allclose(ds.train.c2w[:, :3, 2], np.tile([0, 0, 1.0], (4, 1)), atol=1e-6)
  o, d = ds.test.rays()
  np.testing.assert_allclose(o[..., 2], -1.0, atol=1e-5)   # on the NDC near plane
  np.testing.assert_allclose(d[..., 2], 2.0, atol=1e-5)    # from there to infinity


@pytest.mark.parametrize("edit, message", [
    (lambda r: os.remove(os.path.join(r, "poses_bounds.npy")), "poses_bounds.npy: file not found"),
    (lambda r: np.save(os.path.join(r, "poses_bounds.npy"), np.zeros((6, 15))),
     r"shape \(6, 15\), expected \(N, 17\)"),
    (lambda r: np.save(os.path.join(r, "poses_bounds.npy"),
                       np.where(np.arange(17) == 3, np.nan, np.load(os.path.join(r, "poses_bounds.npy")))),
     "row 0 is not finite"),
    (lambda r: os.remove(os.path.join(r, "images_2", "image005.png")), "5 images but 6 rows"),
])
def test_bad_llff_input(tmp_path, edit, message):
  root = write_llff(str(tmp_path / "scene"))
  edit(root)
  with pytest.raises(datasets.DataError, match=message):
    datasets.load(llff_config(root).data)


@pytest.mark.slow
def test_forward_facing_stages_smoke(tmp_path):
  root = write_llff(str(tmp_path / "scene"))
  c = llff_config(root)
  assert pipeline.needed(c) == ("lo", "ray", "hi")
  for name in ("lo", "hi"):
    c[name].update(steps=60, log_every=1, lr_init=5e-3, lr_final=5e-3)
  wd = str(tmp_path / "run")
  infos = pipeline.run(finish(c), wd)
  assert np.isfinite(infos["hi"]["eval"]["psnr"])
  assert infos["ray"]["step"] == c.ray.steps
  for name in ("lo", "hi"):
    assert_trained(wd, name, c)


@pytest.mark.skipif(not os.path.exists(FERN), reason="shared LLFF data absent")
def test_fern_split_and_ndc_bounds():
  from configs import llff
  c = editable(llff.get_config("fern_4view_cpu"), "halo")
  c.data.root = FERN
  ds = datasets.load(c.data)
  assert ds.train.images.shape == (4, 378, 504, 3) and ds.test.names == ("014",)
  o, d = ds.train.rays()
  assert np.all(np.isfinite(o)) and np.all(np.isfinite(d))
  np.testing.assert_allclose(o[..., 2], -1.0, atol=1e-4)


@pytest.mark.slow
def test_joint_scheme_smoke(tmp_path):
  import json
  root = write_llff(str(tmp_path / "scene"))
  c = llff_config(root)
  c.hi.sampler.kind = "joint"
  c.stages = "lo,hi"
  c.hi.joint.update(alpha_steps=4, alpha_final=0.3)
  assert pipeline.needed(c) == ("lo", "hi")  # the ray field trains inside hi
  wd = str(tmp_path / "run")
  infos = pipeline.run(finish(c), wd)
  assert np.isfinite(infos["hi"]["eval"]["psnr"])
  log = [json.loads(l) for l in open(os.path.join(wd, "metrics.jsonl"))]
  hi = [r for r in log if r.get("stage") == "hi" and "loss" in r]
  # logged at steps 2, 4, 6 from the step counts 1, 3, 5: 1 - 0.7 * min(s / 4, 1)
  assert [r["alpha"] for r in hi] == pytest.approx([0.825, 0.475, 0.3])
  assert all(np.isfinite(r["consist"]) for r in hi)
  # a relaunch of hi alone loads the joint state's structure
  c.stages = "hi"
  c.hi.steps = 6
  assert pipeline.run(finish(c), wd)["hi"]["step"] == 6


def test_regnerf_split_of_twenty_images():
  """RegNeRF's rule worked by hand for fern's 20 images: 000, 008, 016 held
  out; the 17 left indexed at round(linspace(0, 16, k)), halves to even."""
  names = [f"{i:03d}" for i in range(20)]
  assert datasets.spread_views(names, 3, 8) == ["001", "010", "019"]
  assert datasets.spread_views(names, 6, 8) == ["001", "004", "007", "012", "015", "019"]
  assert datasets.spread_views(names, 9, 8) == ["001", "003", "005", "007", "010", "012",
                                                "014", "017", "019"]
  with pytest.raises(datasets.DataError, match="17 views are left"):
    datasets.spread_views(names, 18, 8)


@pytest.mark.skipif(not os.path.isdir(os.path.join(SHARED_DATA, "nerf_llff_data", "fern")),
                    reason="needs nerf_llff_data/fern")
def test_fern_regnerf_3view_config_loads_its_split(monkeypatch):
  from configs import llff as llff_cfg
  monkeypatch.setenv("HALO_DATA", SHARED_DATA)
  c = editable(llff_cfg.get_config("fern_3view_cpu"), "halo")
  ds = datasets.load(c.data)
  assert ds.train.names == ("001", "010", "019") and ds.test.names == ("000", "008", "016")


def test_rays_between_training_rays_are_ndc_rays_between_their_cameras(tmp_path):
  """camera.rays_between on a rig's NDC rays: every mix starts on the near
  plane and reaches the far plane in one step (o_z = -1, d_z = 2), and a mix
  of two rays is the ray of the pixel between theirs seen from between their
  cameras (NDC is affine in both for cameras that share a rotation)."""
  import jax
  root = write_llff(str(tmp_path / "scene"))
  ds = datasets.load(llff_config(root).data)
  o, d = ds.train.rays()
  o, d = o.reshape(-1, 3), d.reshape(-1, 3)
  mo, md = (np.asarray(x) for x in camera.rays_between(jax.random.PRNGKey(0), o, d, 4096))
  np.testing.assert_allclose(mo[:, 2], -1.0, atol=1e-5)
  np.testing.assert_allclose(md[:, 2], 2.0, atol=1e-5)
  # inside the training rays' box, and spread over it (not the training rays)
  for x, ref in ((mo, o), (md, d)):
    assert np.all(x.min(0) >= ref.min(0) - 1e-6) and np.all(x.max(0) <= ref.max(0) + 1e-6)
  dist = np.min(np.abs(mo[:256, None, :2] - o[None, :, :2]).sum(-1), axis=1)
  assert np.median(dist) > 1e-3
  # the mid mix of one pixel seen by cameras 0 and 1 (centres 0 and 0.1 in x)
  # is that pixel's ray from the camera at x = 0.05
  rig = datasets.load(llff_config(root).data)
  c2w = np.asarray(rig.train.c2w[:2])
  mid = c2w[0].copy()
  mid[:3, 3] = 0.5 * (c2w[0][:3, 3] + c2w[1][:3, 3])
  h, w, f = rig.train.height, rig.train.width, rig.train.focal
  world = [camera.pixel_rays(m, h, w, f) for m in (c2w[0], c2w[1], mid)]
  ndc = [camera.ndc_rays(np.asarray(wo), np.asarray(wd), h, w, f) for wo, wd in world]
  np.testing.assert_allclose(0.5 * (ndc[0][0] + ndc[1][0]), ndc[2][0], atol=1e-5)
  np.testing.assert_allclose(0.5 * (ndc[0][1] + ndc[1][1]), ndc[2][1], atol=1e-5)


@pytest.mark.slow
def test_forward_facing_ray_field_trains_on_random_rays(tmp_path):
  root = write_llff(str(tmp_path / "scene"))
  c = llff_config(root)
  c.ray.update(random_fraction=0.5, bank_rays=512)
  c.stages = "lo,ray"
  infos = pipeline.run(finish(c), str(tmp_path / "run"))
  assert infos["ray"]["step"] == c.ray.steps
