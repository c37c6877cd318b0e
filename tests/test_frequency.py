"""The frequency criterion on constructed cases, camera pairs, and the search."""
import json
import os
import re
import subprocess
import sys

import jax.numpy as jnp
import numpy as np
import pytest

from halo_jax import pipeline
from halo_jax.frequency import spectrum as frequency, tuning
from halo_jax.configure import finish  # pylint: disable=g-import-not-at-top

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
H, W = 32, 40


def grating(shift=0.0, k=3, amplitude=50.0):
  """Grey 128 + A cos(2 pi k (x - shift) / W) as a [1, H, W, 3] image in [0, 1]."""
  x = np.arange(W)
  row = 128.0 + amplitude * np.cos(2 * np.pi * k * (x - shift) / W)
  img = np.broadcast_to(row[None, :, None], (H, W, 3)) / 255.0
  return jnp.asarray(img[None], jnp.float32)


def test_identical_images_give_zero():
  a = jnp.asarray(np.random.default_rng(0).uniform(size=(3, H, W, 3)), jnp.float32)
  assert float(frequency.spectrum_difference(a, a)) == 0.0


def test_shifted_grating_matches_closed_form():
  # Unitary FFT: the grating has two coefficients of magnitude A sqrt(HW) / 2;
  # a shift by d turns each by 2 pi k d / W, so |dF| = A sqrt(HW) |sin(pi k d / W)|
  # at both, and the mean over the H W - 1 kept coefficients (DC dropped) is
  # 2 A sqrt(HW) |sin(pi k d / W)| / (H W - 1).
  k, amp = 3, 50.0
  for d in (0.5, 2.0, 5.0):
    got = float(frequency.spectrum_difference(grating(0, k, amp), grating(d, k, amp), 0.0))
    want = 2 * amp * np.sqrt(H * W) * abs(np.sin(np.pi * k * d / W)) / (H * W - 1)
    np.testing.assert_allclose(got, want, rtol=1e-4)
  # A shift by a whole period changes nothing.
  period = W / k
  assert float(frequency.spectrum_difference(grating(0, k), grating(period * 3, k), 0.0)) < 1e-4 * amp


def test_mask_drops_dc_and_exactly_the_largest_coefficients():
  a, b = grating(0.0), grating(2.0)
  fa, fb = (jnp.fft.fft2(frequency.grey_255(x), norm="ortho") for x in (a, b))
  for num_drop in (0, 2, 10):
    keep = np.asarray(frequency.spectrum_mask(fa, fb, num_drop / (H * W)))[0]
    assert keep.sum() == H * W - 1 - num_drop and not keep[0, 0]
  # Dropping the grating's two coefficients leaves nothing that moved.
  assert float(frequency.spectrum_difference(a, b, 2 / (H * W))) < 1e-3
  keep = np.asarray(frequency.spectrum_mask(fa, fb, 2 / (H * W)))[0]
  assert not keep[0, 3] and not keep[0, W - 3]


def test_grid_is_searched_from_high_to_low_frequency():
  assert tuning.parse_grid("5:32,10:1,5:8,6:1") == [(10, 1.0), (6, 1.0), (5, 8.0), (5, 32.0)]
  with pytest.raises(ValueError, match="expected 'L:s"):
    tuning.parse_grid("5-32")


def _tiny_tune(config, scene_root, grid, threshold):
  config.data.root = scene_root
  config.tune.update(grid=grid, threshold=threshold, num_pairs=2, lo_steps=4, size=16)
  return config


@pytest.mark.slow
def test_search_stops_at_first_point_below_threshold(config, scene_root, tmp_path):
  from halo_jax import datasets
  _tiny_tune(config, scene_root, "6:1,3:8", 1e9)
  ds = datasets.load(config.data)
  res = tuning.tune(config, str(tmp_path / "a"), ds, pipeline.run)
  assert [(g["L"], g["scale"]) for g in res["grid"]] == [(6, 1.0)]
  assert res["chosen"] == {"L": 6, "scale": 1.0} and res["below_threshold"]
  full = tuning.tune(config, str(tmp_path / "b"), ds, pipeline.run, full_grid=True)
  assert [(g["L"], g["scale"]) for g in full["grid"]] == [(6, 1.0), (3, 8.0)]
  assert all(g["criterion"] > 0 and np.isfinite(g["psnr"]) for g in full["grid"])
  config.tune.threshold = 0.0
  none = tuning.tune(config, str(tmp_path / "b"), ds, pipeline.run)   # reuses the trained points
  assert none["chosen"] == {"L": 3, "scale": 8.0} and not none["below_threshold"]
  saved = json.load(open(os.path.join(tmp_path, "b", "results.json")))
  assert saved["chosen"] == none["chosen"]


@pytest.mark.slow
def test_auto_encoding_searches_then_trains_lo_with_the_choice(config, scene_root, tmp_path):
  _tiny_tune(config, scene_root, "6:1,3:8", 0.0)
  config.stages = "lo"
  config.lo.encoding.auto = True
  wd = str(tmp_path / "run")
  pipeline.run(finish(config), wd)
  saved = json.load(open(os.path.join(wd, "lo", "final", "config.json")))
  assert (saved["lo"]["encoding"]["L"], saved["lo"]["encoding"]["scale"]) == (3, 8.0)
  assert os.path.exists(os.path.join(wd, "tune", "results.json"))


@pytest.mark.slow
def test_sweep_cli_two_points(scene_root, tmp_path):
  wd = str(tmp_path / "sweep")
  cmd = [sys.executable, "-m", "halo_jax.cli.sweep", "--config=configs/default.py", f"--workdir={wd}",
         f"--config.data.root={scene_root}", "--config.stages=lo", "--config.lo.steps=3",
         "--config.lo.model.width=16", "--config.lo.model.depth=2", "--config.lo.batch_rays=64",
         "--config.lo.sampler.num_samples=8", "--config.data.factor=2",
         "--config.data.test_views=r_0", "--config.protocol=steps", "--config.budget_s=0", "--config.tune.num_pairs=2",
         "--sweep=lo.encoding.L=3,6", "--sweep=lo.encoding.scale=8"]
  res = subprocess.run(cmd, cwd=REPO, capture_output=True, text=True, timeout=300)
  assert res.returncode == 0, res.stderr[-3000:]
  rows = json.load(open(os.path.join(wd, "results.json")))["points"]
  assert [r["point"] for r in rows] == [{"lo.encoding.L": 3, "lo.encoding.scale": 8.0},
                                        {"lo.encoding.L": 6, "lo.encoding.scale": 8.0}]
  assert all(r["criterion"] is not None for r in rows)
  # each row is its own point's held-out score, and the override reached the
  # run: the two frequencies train different fields
  for r in rows:
    ev = json.load(open(os.path.join(wd, r["label"], "lo", "eval", "metrics.json")))
    assert r["psnr"] == pytest.approx(ev["psnr"])
  assert rows[0]["psnr"] != rows[1]["psnr"]
  assert "| lo.encoding.L=3,lo.encoding.scale=8 |" in res.stdout
  # the sweep's bar counts its points on stderr, never on the piped table
  assert re.search(r"sweep: 100%.*\| 2/2 \[", res.stderr) and "2/2" not in res.stdout
  assert os.path.exists(os.path.join(wd, "sweep.png"))


def _pair(seed=0, n=32):
  rng = np.random.default_rng(seed)
  a = rng.uniform(0.1, 0.4, (2, n, n, 3)).astype(np.float32)
  b = np.clip(a + rng.normal(0, 0.05, a.shape), 0, None).astype(np.float32)
  return a, b


def test_relative_criterion_is_scale_free():
  a, b = _pair()
  rho = float(frequency.relative_spectrum_difference(a, b, 0.01))
  assert rho > 0.05
  # brightened by 2x
  assert float(frequency.relative_spectrum_difference(2 * a, 2 * b, 0.01)) == pytest.approx(
      rho, abs=1e-3)
  # rendered at twice the size (each pixel a 2x2 block), scored at the criterion size
  up = lambda x: np.repeat(np.repeat(x, 2, 1), 2, 2)
  assert float(frequency.relative_spectrum_difference(up(a), up(b), 0.01, size=32)) == \
      pytest.approx(rho, abs=1e-3)
  # another FFT normalisation: the ratio cancels it (ortho by hand)
  fa = np.fft.fft2(a.mean(-1), norm="ortho")
  fb = np.fft.fft2(b.mean(-1), norm="ortho")
  keep = np.asarray(frequency.spectrum_mask(jnp.asarray(fa), jnp.asarray(fb), 0.01))
  by_hand = np.mean([(np.abs(fa - fb) * keep).sum((1, 2)) /
                     (0.5 * (np.abs(fa) + np.abs(fb)) * keep).sum((1, 2))])
  assert by_hand == pytest.approx(rho, abs=1e-3)


def test_relative_criterion_identical_and_grating_closed_form():
  a, _ = _pair()
  assert float(frequency.relative_spectrum_difference(a, a)) == 0.0
  n, k = 64, 5
  x = np.arange(n)
  for d in (1, 2, 3):
    img_a = 0.5 + 0.25 * np.cos(2 * np.pi * k * x / n)
    img_b = 0.5 + 0.25 * np.cos(2 * np.pi * k * (x - d) / n)
    ga = np.broadcast_to(img_a, (1, n, n)).astype(np.float32)
    gb = np.broadcast_to(img_b, (1, n, n)).astype(np.float32)
    rho = float(frequency.relative_spectrum_difference(ga, gb, mask_fraction=0.0))
    assert rho == pytest.approx(2 * abs(np.sin(np.pi * k * d / n)), abs=1e-4)


def test_sweep_values_with_commas_are_a_json_list(config):
  from halo_jax.cli import sweep  # pylint: disable=g-import-not-at-top
  points = sweep.parse_sweeps(config, ['data.train_views=["r_0,r_13", "r_0,r_13,r_26"]',
                                       "lo.encoding.L=3,5"])
  assert [p[0] for p in points] == [("data.train_views", "r_0,r_13")] * 2 + [
      ("data.train_views", "r_0,r_13,r_26")] * 2
  assert [p[1][1] for p in points] == [3, 5, 3, 5]
  with pytest.raises(ValueError, match="not JSON"):
    sweep.parse_sweeps(config, ["data.train_views=[r_0"])


def _rows(points):
  return [{"L": L, "scale": sc, "criterion": c} for L, sc, c in points]


def test_decide_never_returns_hi_frequency_silently():
  grid = [(10, 1.0), (8, 1.0), (5, 1.0), (5, 32.0)]
  hi = 2.0 ** 9  # Hi-NeRF's L=10, s=1
  # a plain pick: the first point below the threshold, after one above it
  chosen, note = tuning.decide(_rows([(10, 1, 30.0), (8, 1, 20.0)]), grid, 25.0, hi)
  assert chosen == {"L": 8, "scale": 1.0} and note == {"below_threshold": True, "text": ""}
  # the first point, Hi-NeRF's own frequency, already passes: the next one down, said
  chosen, note = tuning.decide(_rows([(10, 1, 3.0)]), grid, 25.0, hi)
  assert chosen == {"L": 8, "scale": 1.0}
  assert "does not bracket" in note["text"] and "L=8, s=1" in note["text"]
  # none passes: the lowest-frequency point, said
  chosen, note = tuning.decide(_rows([(10, 1, 40.0), (8, 1, 35.0), (5, 1, 30.0),
                                      (5, 32, 26.0)]), grid, 25.0, hi)
  assert chosen == {"L": 5, "scale": 32.0} and not note["below_threshold"]
  assert "no grid point fell below the threshold 25" in note["text"]
  # a first point already below Hi-NeRF's frequency that passes: kept, with a warning
  chosen, note = tuning.decide(_rows([(8, 1, 3.0)]), grid[1:], 25.0, hi)
  assert chosen == {"L": 8, "scale": 1.0} and "may not reach high enough" in note["text"]


def test_decide_never_chooses_a_collapsed_point():
  grid = [(10, 1.0), (8, 1.0), (5, 1.0), (5, 32.0)]
  hi = 2.0 ** 9
  rows = _rows([(10, 1, 30.0), (8, 1, 20.0), (5, 1, 10.0), (5, 32, 5.0)])
  rows[1]["collapsed"] = True   # below the threshold, but it learned nothing
  chosen, note = tuning.decide(rows, grid, 25.0, hi)
  assert chosen == {"L": 5, "scale": 1.0} and note["below_threshold"]
  # none passes and the lowest-frequency point collapsed: the lowest that learned
  rows = _rows([(10, 1, 40.0), (8, 1, 35.0), (5, 1, 30.0), (5, 32, 26.0)])
  rows[3]["collapsed"] = True
  chosen, _ = tuning.decide(rows, grid, 25.0, hi)
  assert chosen == {"L": 5, "scale": 1.0}
  # every point collapsed: no choice, said loudly
  for r in rows:
    r["collapsed"] = True
  with pytest.raises(RuntimeError, match="every grid point's Lo-NeRF collapsed"):
    tuning.decide(rows, grid, 25.0, hi)


def test_tune_keeps_a_collapsed_point_and_passes_over_it(config, tmp_path, monkeypatch):
  """The search goes on past a grid point whose Lo-NeRF collapsed: the point is
  in the grid, marked, and the choice is the next one that passes."""
  from halo_jax.stages import collapse
  verdict = {"verdict": collapse.COLLAPSED, "window": [1, 2], "train_psnr": 10.0,
             "constant_psnr": 10.0, "margin_db": 1.0}

  def run_stages(c, wd, dataset):
    info = {"wall_s": 1.0, "step": 4, "eval": {"psnr": 12.0}}
    if c.lo.encoding.L == 6:
      raise collapse.Collapsed("lo", verdict, {"lo": dict(info, learned=verdict)})
    return {"lo": info}

  crit = {6: 0.1, 3: 0.2}   # both below the threshold; the collapsed one first
  monkeypatch.setattr(tuning.base, "trainer_of",
                      lambda c, n: type("T", (), {"params_like": lambda *a: None,
                                                  "requires": lambda *a: ()})())
  monkeypatch.setattr(tuning, "load", lambda *a: None)
  monkeypatch.setattr(tuning, "lo_renderer", lambda c, d, s: c.lo.encoding.L)
  monkeypatch.setattr(tuning, "criterion_of", lambda L, d, c: {
      "criterion": crit[L], "per_pair": [], "criterion_plain": crit[L],
      "criterion_warped": crit[L], "shift_px": [], "pair_kind": "orbit"})
  config.tune.update(grid="6:1,3:8", threshold=1.0, relative=False)
  res = tuning.tune(config, str(tmp_path), None, run_stages)
  assert [g["collapsed"] for g in res["grid"]] == [True, False]
  assert res["chosen"] == {"L": 3, "scale": 8.0}
