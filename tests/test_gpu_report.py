"""experiments/gpu_report.py and rescore_renders.py, on made-up result files
and renders (no GPU)."""
import json
import os

import imageio.v3 as iio
import numpy as np
import pytest

from experiments import rescore_renders
from experiments.bench import gpu_report


def _run(seed, methods):
  return {"scene": "s", "config": "configs/x.py:s", "seed": seed, "budget_s": 10,
          "date": "2026-01-01", "device": "GPU",
          "methods": {m: {"psnr": p, "ssim": 0.5, "lpips": None, "num_views": 2, "wall_s": 10.0,
                          "stages": {"hi": {"step": 100}}, "curve": [[5.0, p - 1], [10.0, p]]}
                      for m, p in methods.items()}}


def test_mean_only_over_seeds_with_every_method(tmp_path):
  root = tmp_path / "results"
  (root / "s").mkdir(parents=True)
  runs = [_run(0, {"halo": 20.0, "nerf_tuned": 19.0}), _run(1, {"halo": 22.0, "nerf_tuned": 21.0}),
          _run(2, {"halo": 30.0})]
  for r in runs:
    (root / "s" / f"seed{r['seed']}.json").write_text(json.dumps(r))
  text = gpu_report.page(gpu_report.load(str(root)), str(tmp_path))
  assert "| 2 | halo | 30.00 |" in text
  # seed 2 lacks nerf_tuned: the mean is over seeds 0 and 1 only
  assert "seeds [0, 1]" in text and "| halo | 21.00 ± 1.41 |" in text
  assert (tmp_path / "gpu_s.png").stat().st_size > 0


def test_rescore_reads_the_middle_panel(tmp_path, monkeypatch):
  """The render is the strip's middle third ([truth | render | depth])."""
  truth = np.random.default_rng(0).uniform(0.2, 0.8, (1, 16, 16, 3)).astype(np.float32)
  render = np.clip(truth + 0.1, 0, 1)
  eval_dir = tmp_path / "halo" / "hi" / "eval"
  (tmp_path / "halo" / "hi" / "final").mkdir(parents=True)
  eval_dir.mkdir()
  (eval_dir / "metrics.json").write_text("{}")
  to8 = lambda x: (x * 255).round().astype(np.uint8)
  strip = np.concatenate([to8(truth[0]), to8(render[0]), np.zeros((16, 16, 3), np.uint8)], 1)
  iio.imwrite(eval_dir / "v0.png", strip)

  class Views:
    names = ["v0"]
    images = truth

  class Data:
    test = Views()

  class Config:
    data = type("D", (), {"root": ""})()

  monkeypatch.setattr(rescore_renders.checkpoint, "read_config", lambda p: Config())
  monkeypatch.setattr(rescore_renders.datasets, "load", lambda c, w: Data())
  # the real scorer on the middle panel; only LPIPS (VGG weights) is stood in for
  monkeypatch.setattr(rescore_renders.evaluate.metrics, "lpips",
                      lambda rgb, target: np.zeros(len(rgb)))
  out = rescore_renders.rescore_method(str(tmp_path / "halo"), "")
  # closed form, in numpy, of the 8-bit render against the float truth
  expected = -10 * np.log10(np.mean((to8(render[0]) / 255.0 - truth[0]) ** 2))
  assert abs(out["psnr_8bit"] - expected) < 1e-3
  # a panel off by one (the depth or the truth) would score far from it
  assert abs(expected - (-10 * np.log10(np.mean(truth[0] ** 2)))) > 5
  assert os.path.basename(next(iter(out["per_view"]))) == "v0"


def test_rescore_picks_the_named_stage(tmp_path, monkeypatch):
  """A three-stage method saves Lo's renders and Hi's: unnamed, the stage is
  ambiguous and refused; named, only that stage's renders are read."""
  truth = np.full((1, 8, 8, 3), 0.5, np.float32)
  to8 = lambda x: (x * 255).round().astype(np.uint8)
  for stage, value in (("lo", 0.1), ("hi", 0.45)):
    d = tmp_path / "halo" / stage / "eval"
    d.mkdir(parents=True)
    (d / "metrics.json").write_text("{}")
    panel = to8(np.full((8, 8, 3), value))
    depth = to8(np.full((8, 8, 3), 0.95))  # unlike the render: reading it would fail
    iio.imwrite(d / "v0.png", np.concatenate([to8(truth[0]), panel, depth], 1))

  class Views:
    names = ["v0"]
    images = truth

  monkeypatch.setattr(rescore_renders.checkpoint, "read_config",
                      lambda p: type("C", (), {"data": type("D", (), {"root": ""})()})())
  monkeypatch.setattr(rescore_renders.datasets, "load",
                      lambda c, w: type("Data", (), {"test": Views()})())
  monkeypatch.setattr(rescore_renders.evaluate.metrics, "lpips",
                      lambda rgb, target: np.zeros(len(rgb)))
  with pytest.raises(ValueError, match="expected one stage"):
    rescore_renders.rescore_method(str(tmp_path / "halo"), "")
  out = rescore_renders.rescore_method(str(tmp_path / "halo"), "", "hi")
  expected = -10 * np.log10((to8(np.full(1, 0.45))[0] / 255.0 - 0.5) ** 2)
  assert abs(out["psnr_8bit"] - expected) < 1e-3
