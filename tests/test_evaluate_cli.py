"""`halo-eval` (halo_jax/cli/evaluate.py): restores a finished stage, reproduces the
metrics its training recorded, writes nerfbaselines' layout."""
import json
import os
import subprocess
import sys

import imageio.v3 as iio
import numpy as np
import pytest

from halo_jax import pipeline
from halo_jax.cli import evaluate as evaluate_cli
from conftest import pipeline_config
from halo_jax.configure import finish  # pylint: disable=g-import-not-at-top


@pytest.fixture(scope="module")
def finished_run(scene_root, tmp_path_factory):
  wd = str(tmp_path_factory.mktemp("run"))
  c = pipeline_config(scene_root, steps=4)
  infos = pipeline.run(finish(c), wd)
  return wd, infos


def test_evaluate_reproduces_training_metrics(finished_run):
  wd, infos = finished_run
  r = evaluate_cli.run_evaluation(wd)  # default stage: the run's output stage, hi
  assert r["stage"] == "hi" and r["num_views"] == 2
  recorded = infos["hi"]["eval"]
  for k in ("psnr", "ssim", "lpips"):
    assert r["float"][k] == pytest.approx(recorded[k], abs=1e-4)
  # 8-bit rounding moves PSNR a little, not a lot
  assert r["uint8"]["psnr"] != r["float"]["psnr"]
  assert abs(r["uint8"]["psnr"] - r["float"]["psnr"]) < 0.1
  out = r["out"]
  for sub, ext in (("color", "png"), ("gt-color", "png"), ("depth", "npy"),
                   ("depth-rgb", "png"), ("acc", "png")):
    assert sorted(os.listdir(os.path.join(out, sub))) == [f"r_0.{ext}", f"r_100.{ext}"]
  assert np.load(os.path.join(out, "depth", "r_0.npy")).dtype == np.float32
  assert iio.imread(os.path.join(out, "color", "r_0.png")).shape == (32, 32, 3)
  info = json.load(open(os.path.join(out, "info.json")))
  assert info["evaluation_protocol"] == "nerf" and info["stage"] == "hi"
  for field in ("versions", "device", "cpu", "code", "command"):
    assert field in info["provenance"]
  saved = json.load(open(os.path.join(out, "metrics.json")))
  assert set(saved["float"]["per_view"]) == {"r_0", "r_100"}


def test_evaluate_other_stage_and_split(finished_run, capsys):
  wd, infos = finished_run
  r = evaluate_cli.run_evaluation(wd, stage="lo", with_lpips=False)
  err = capsys.readouterr().err
  assert "evaluate lo on test: 100%" in err and "| 2/2 [" in err
  assert r["float"]["psnr"] == pytest.approx(infos["lo"]["eval"]["psnr"], abs=1e-4)
  train = evaluate_cli.run_evaluation(wd, split="train", with_lpips=False)
  assert train["num_views"] == 4
  some = evaluate_cli.run_evaluation(wd, split="test", views="r_5,r_6", with_lpips=False)
  assert sorted(some["float"]["per_view"]) == ["r_5", "r_6"]


def test_evaluate_refuses_a_stage_without_images(finished_run, tmp_path):
  wd, _ = finished_run
  proc = subprocess.run([sys.executable, "-m", "halo_jax.cli.evaluate", f"--workdir={wd}",
                         "--stage=ray"], capture_output=True, text=True)
  assert proc.returncode == 2
  assert "stage 'ray' (ray_field) makes no images" in proc.stderr
  assert "Traceback" not in proc.stderr
  proc = subprocess.run([sys.executable, "-m", "halo_jax.cli.evaluate",
                         f"--workdir={tmp_path}"], capture_output=True, text=True)
  assert proc.returncode == 2 and "no finished stage" in proc.stderr
