"""Dynamic scenes: the D-NeRF loaders, the every-8th split, time in the
encoding, the flicker measure, and a smoke run of HALO for time."""
import json
import os

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from conftest import assert_trained, SHARED_DATA, tiny_config
from halo_jax import configure, datasets, methods, metrics, models, pipeline, raycast, stages
from halo_jax.datasets import blender
from halo_jax.stages import transfer
from conftest import editable  # pylint: disable=g-import-not-at-top
from halo_jax.configure import finish  # pylint: disable=g-import-not-at-top

TINY_DNERF = os.path.join(SHARED_DATA, "dnerf", "tiny_dnerf_data.npz")


def write_npz(path, scene_root, n_train=24, n_val=2, n_test=4, **override):
  """A packed D-NeRF file built from the procedural scene's views (static
  content, times 0..1 within each split), like tiny_dnerf_data.npz."""
  train = blender.load_views(scene_root, "train", 2, None, True)
  test = blender.load_views(scene_root, "test", 2, None, True)
  images = np.concatenate([train.images[:n_train], test.images[:n_val + n_test]])
  poses = np.concatenate([train.c2w[:n_train], test.c2w[:n_val + n_test]])
  times = np.concatenate([np.linspace(0, 1, n) for n in (n_train, n_val, n_test)])
  arrays = dict(images=images, poses=poses, times=times.astype(np.float32),
                focal=np.float64(train.focal))
  arrays.update(override)
  np.savez(path, **arrays)
  return path


def dynamic_config(root, method="halo"):
  c = tiny_config(method="")
  c.data.update(kind="dnerf", root=root, factor=1, train_views="every:8",
                test_views="test_000,test_003")
  for name in ("lo", "hi"):
    c[name].model.update(kind="deform", deform_width=16, deform_depth=2)
  c.lo.encoding.update(L=2, time_L=2)
  c.hi.encoding.update(L=6, time_L=4)
  c.eval.flicker_frames = 4
  return methods.apply(c, method)


def test_npz_splits_and_every_eighth_image(scene_root, tmp_path):
  path = write_npz(str(tmp_path / "d.npz"), scene_root)
  c = dynamic_config(path).data
  ds = datasets.load(c)
  assert ds.train.names == ("train_000", "train_008", "train_016")
  np.testing.assert_allclose(ds.train.times, np.linspace(0, 1, 24)[::8], rtol=1e-6)
  assert ds.test.names == ("test_000", "test_003")
  np.testing.assert_allclose(ds.test.times, [0.0, 1.0])
  assert ds.train.ray_times().shape == (3, 32, 32, 1)
  assert float(ds.train.ray_times()[1, 5, 7, 0]) == pytest.approx(8 / 23)


@pytest.mark.skipif(not os.path.exists(TINY_DNERF), reason="shared D-NeRF data absent")
def test_tiny_dnerf_lego_split():
  from configs import dnerf
  c = editable(dnerf.get_config("tiny_cpu"), "halo")
  c.data.root = TINY_DNERF
  ds = datasets.load(c.data)
  # 50 training frames, every 8th: frames 0, 8, ..., 48.
  assert ds.train.names == tuple(f"train_{i:03d}" for i in range(0, 50, 8))
  assert ds.test.images.shape == (20, 100, 100, 3)
  assert ds.test.times[0] == 0.0 and ds.test.times[-1] == 1.0


@pytest.mark.parametrize("scene, num_train", [("lego", 7), ("hook", 13), ("jumpingjacks", 25)])
def test_dnerf_scene_folders_cpu_protocol(scene, num_train):
  """Any D-NeRF scene by name: every 8th training frame, the 20 test frames,
  100x100 on white (the paper's 400x400 protocol at factor 8)."""
  from configs import dnerf
  c = editable(dnerf.get_config(f"{scene}_cpu"), "halo")
  c.data.root = os.path.join(SHARED_DATA, "dnerf", scene)
  if not os.path.isdir(c.data.root):
    pytest.skip("shared D-NeRF scene folders absent")
  assert c.data.white_background and c.data.factor == 8
  ds = datasets.load(c.data)
  assert ds.train.images.shape == (num_train, 100, 100, 3)
  assert ds.test.images.shape == (20, 100, 100, 3)
  # composited on white: the corners are background
  np.testing.assert_allclose(ds.test.images[:, 0, 0], 1.0, atol=1e-2)
  assert dnerf.get_config(scene).data.factor == 2


@pytest.mark.parametrize("override, message", [
    (dict(times=None), "missing array 'times'"),
    (dict(poses=np.full((30, 4, 4), np.nan, np.float32)), r"'poses'\[0\] is not finite"),
    (dict(times=np.linspace(0, 1, 30).astype(np.float32)), "restart 0 times"),
    (dict(focal=np.float64(-1.0)), "'focal' must be a positive number"),
])
def test_bad_npz_names_the_field(scene_root, tmp_path, override, message):
  path = str(tmp_path / "bad.npz")
  write_npz(path, scene_root, **{k: v for k, v in override.items() if v is not None})
  if any(v is None for v in override.values()):
    arrays = dict(np.load(path))
    np.savez(path, **{k: v for k, v in arrays.items() if k not in override})
  with pytest.raises(datasets.DataError, match=message):
    datasets.load(dynamic_config(path).data)


def test_json_layout_reads_time_and_requires_it_everywhere(scene_root, tmp_path):
  import shutil
  root = str(tmp_path / "dn")
  shutil.copytree(scene_root, root)
  for split in ("train", "test"):
    p = os.path.join(root, f"transforms_{split}.json")
    meta = json.load(open(p))
    for i, fr in enumerate(meta["frames"]):
      fr["time"] = i / (len(meta["frames"]) - 1)
    json.dump(meta, open(p, "w"))
  c = dynamic_config(root).data
  c.update(factor=2, train_views="every:40", test_views="r_0")
  ds = datasets.load(c)
  np.testing.assert_allclose(ds.train.times, [0.0, 40 / 99, 80 / 99], rtol=1e-6)
  p = os.path.join(root, "transforms_train.json")
  meta = json.load(open(p))
  del meta["frames"][40]["time"]
  json.dump(meta, open(p, "w"))
  with pytest.raises(datasets.DataError, match="'time' is on some frames but not on r_40"):
    datasets.load(c)


@pytest.mark.slow
def test_time_has_its_own_frequencies():
  m = models.DeformNeRF(pos_freqs=3, time_freqs=5, width=8, depth=1, skips=(),
                        use_viewdirs=False, deform_width=8, deform_depth=1)
  p = models.init_nerf(m, "deform", 0)
  # deformation input: x encoded with L=3 (3 * 7) and t with its own L=5 (11)
  assert p["deform"]["dense_0"]["kernel"].shape == (3 * 7 + 11, 8)
  # the offset starts at zero: the field starts static in time
  x = jax.random.normal(jax.random.PRNGKey(1), (20, 3))
  a = m.apply({"params": p}, x, None, times=jnp.zeros((20, 1)))
  b = m.apply({"params": p}, x, None, times=jnp.ones((20, 1)))
  np.testing.assert_allclose(a[0], b[0])
  # once it moves, the output depends on t through the 2^4-cycle feature too
  p = jax.tree_util.tree_map(lambda v: v, p)
  p["offset"]["kernel"] = jnp.ones_like(p["offset"]["kernel"])
  f = lambda t: m.apply({"params": p}, x[:1], None, times=jnp.full((1, 1), t))[0].sum()
  assert abs(float(jax.grad(f)(0.3))) > 0


def _moving_lo_and_its_copy():
  """A dynamic Lo whose deformation moves, a Hi copied from it (with_lo), and
  points x [50, 3] at times t [50, 1]: (lo, p_lo, hi, p, x, t)."""
  lo = models.DeformNeRF(pos_freqs=2, time_freqs=2, width=16, depth=2, skips=(),
                         use_viewdirs=False, deform_width=8, deform_depth=2)
  hi = models.DeformNeRF(pos_freqs=6, time_freqs=4, base_freqs=2, base_time_freqs=2,
                         width=16, depth=2, skips=(), use_viewdirs=False, deform_width=8,
                         deform_depth=2)
  p_lo = models.init_nerf(lo, "deform", 0)
  p_lo["offset"]["kernel"] = 0.1 * jnp.ones_like(p_lo["offset"]["kernel"])  # a moving Lo
  p = transfer.transfer_from_lo(models.init_nerf(hi, "deform", 1), p_lo, lo_inputs_first=True)
  x = jax.random.normal(jax.random.PRNGKey(2), (50, 3))
  t = jax.random.uniform(jax.random.PRNGKey(3), (50, 1))
  return lo, p_lo, hi, p, x, t


@pytest.mark.slow
def test_hi_starts_as_a_copy_of_lo_in_space_and_time():
  lo, p_lo, hi, p, x, t = _moving_lo_and_its_copy()
  for a, b in zip(lo.apply({"params": p_lo}, x, None, times=t),
                  hi.apply({"params": p}, x, None, times=t)):
    np.testing.assert_allclose(a, b, rtol=1e-5, atol=1e-6)


def test_the_band_mask_on_a_hi_copied_from_lo_hides_only_its_own_bands():
  """hi.freq_reg on HALO's dynamic Hi (budget study's `freq_reg_0.9`): Lo's
  encodings stay open, so the copy is Lo at every mask position, and a Hi
  that has learned high bands loses them at fraction 0."""
  lo, p_lo, hi, p, x, t = _moving_lo_and_its_copy()
  want = lo.apply({"params": p_lo}, x, None, times=t)[0]
  for fraction in (0.0, 0.5):
    np.testing.assert_allclose(
        hi.apply({"params": p}, x, None, times=t, band_fraction=fraction)[0], want,
        rtol=1e-5, atol=1e-6)
  learned = jax.tree_util.tree_map(lambda a: a + 0.05, p)  # weights on the high bands too
  assert not np.allclose(hi.apply({"params": learned}, x, None, times=t, band_fraction=0.0)[0],
                         hi.apply({"params": learned}, x, None, times=t)[0])


def test_flicker_closed_forms():
  t = jnp.linspace(0, 1, 6)[:, None, None, None]
  linear = 0.2 + 0.5 * t * jnp.ones((6, 4, 4, 3))
  assert float(metrics.temporal_flicker(linear)) == pytest.approx(0.0, abs=1e-4)
  blink = jnp.asarray([0.0, 1.0] * 3)[:, None, None, None] * jnp.ones((6, 4, 4, 3))
  assert float(metrics.temporal_flicker(blink)) == pytest.approx(510.0)  # |±2| * 255
  noisy = linear + 0.01 * jax.random.normal(jax.random.PRNGKey(0), linear.shape)
  assert float(metrics.temporal_flicker(noisy)) > 1.0
  with pytest.raises(ValueError, match=">= 3 frames"):
    metrics.temporal_flicker(linear[:2])


@pytest.mark.slow
def test_halo_for_time_smoke(scene_root, tmp_path):
  path = write_npz(str(tmp_path / "d.npz"), scene_root)
  c = dynamic_config(path)
  c.hi.empty.weight = 0.1
  for name in ("lo", "hi"):
    c[name].update(steps=120, checkpoint_every=60, eval_every=60, lr_init=5e-3, lr_final=5e-3,
                   log_every=2, precrop_steps=0)
  assert pipeline.needed(c) == ("lo", "hi")  # no ray field
  wd = str(tmp_path / "run")
  infos = pipeline.run(finish(c), wd)
  ev = infos["hi"]["eval"]
  for name in ("lo", "hi"):
    assert_trained(wd, name, c)
  assert np.isfinite(ev["flicker"]) and ev["flicker"] >= 0
  assert os.path.exists(os.path.join(wd, "hi", "eval", "flicker.png"))
  log = [json.loads(l) for l in open(os.path.join(wd, "metrics.jsonl"))]
  assert any("empty" in r for r in log if r.get("stage") == "hi")


@pytest.mark.slow
@pytest.mark.parametrize("method", ["freenerf", "halo+freenerf", "nerf_paper"])
def test_every_method_trains_on_a_dynamic_scene(method, scene_root, tmp_path):
  """FreeNeRF's mask reaches the deformation field's x and t encodings and its
  canonical NeRF; the original NeRF's coarse MLP is a deformation field too."""
  path = write_npz(str(tmp_path / "d.npz"), scene_root)
  c = dynamic_config(path, method)
  for name in ("lo", "hi"):
    c[name].update(steps=60, microbatches=1, batch_rays=64, checkpoint_every=60, eval_every=0,
                   log_every=1, precrop_steps=0, lr_init=5e-3, lr_final=5e-3)
  c.hi.sampler.update(num_coarse=8, num_samples=8)
  wd = str(tmp_path / "run")
  infos = pipeline.run(finish(c), wd)
  assert np.isfinite(infos["hi"]["eval"]["psnr"])
  for name in infos:
    assert_trained(wd, name, c)
  # the trained method reads time: one view's rays at t = 0 and t = 1 differ
  # (a method that dropped t anywhere would render them bit for bit alike)
  from halo_jax import restore  # pylint: disable=g-import-not-at-top
  run = restore.load(wd, "hi")
  o, d = run.dataset.test.rays()
  o, d = o[:1, ::4, ::4], d[:1, ::4, ::4]
  at = [raycast.render_chunked(run.render, o, d, 1024, np.full(o.shape[:3] + (1,), t,
                                                                np.float32))["rgb"]
        for t in (0.0, 1.0)]
  assert np.abs(at[0] - at[1]).max() > 1e-6


def test_deform_field_band_mask_hides_high_bands():
  model = models.DeformNeRF(pos_freqs=4, time_freqs=3, width=16, depth=2, skips=(),
                            use_viewdirs=False, deform_width=16, deform_depth=2)
  pts = jax.random.uniform(jax.random.PRNGKey(0), (5, 3))
  t = jnp.full((5, 1), 0.3)
  params = model.init(jax.random.PRNGKey(1), pts, None, times=t)
  params = jax.tree_util.tree_map(lambda x: x + 0.1, params)  # a non-zero offset layer
  full = model.apply(params, pts, None, times=t)[0]
  low = model.apply(params, pts, None, times=t, band_fraction=0.0)[0]
  assert not np.allclose(full, low)
  np.testing.assert_allclose(model.apply(params, pts, None, times=t, band_fraction=1.0)[0],
                             full, rtol=1e-6)


def test_static_model_on_dynamic_data_is_refused(scene_root, tmp_path):
  path = write_npz(str(tmp_path / "d.npz"), scene_root)
  c = dynamic_config(path)
  c.lo.model.kind = "nerf"
  wd = str(tmp_path / "run")
  with pytest.raises(ValueError, match="lo.model.kind='nerf' is static .* use 'deform' for scenes "
                     "with times"):
    pipeline.run(finish(c), wd)
  assert not os.path.exists(wd), "refused only after work started"
