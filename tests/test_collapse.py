"""A stage that learned nothing says so (halo_jax/stages/collapse.py): the
verdict's arithmetic, a run built to collapse, and one that learns."""
import json
import os
import subprocess
import sys

import numpy as np
import pytest

from conftest import tiny_config
from halo_jax import pipeline, runs
from halo_jax.stages import collapse

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
JUDGE = dict(margin_db=1.0, after_steps=10, window=0.2)


def test_constant_psnr_is_the_mean_colours():
  # half the pixels black, half white: the mean is grey 0.5, MSE 0.25, 6.02 dB
  rgb = np.concatenate([np.zeros((50, 3)), np.ones((50, 3))])
  assert collapse.constant_psnr(rgb) == pytest.approx(-10 * np.log10(0.25))
  # no constant beats the mean: white (the background alone) does worse
  white_psnr = -10 * np.log10(((rgb - 1.0) ** 2).mean())
  assert collapse.constant_psnr(rgb) > white_psnr
  assert collapse.constant_psnr(np.full((4, 3), 0.3)) == float("inf")


def test_verdicts():
  flat = [(s, 12.1 + 0.1 * (s % 3)) for s in range(0, 101, 10)]
  v = collapse.verdict(flat, 12.0, **JUDGE)
  assert v["verdict"] == "collapsed" and v["window"] == [60, 100]  # at least 5 records
  assert v["train_psnr"] == pytest.approx(12.2)
  rising = [(s, 12.0 + 0.1 * s) for s in range(0, 101, 10)]
  assert collapse.verdict(rising, 12.0, **JUDGE)["verdict"] == "learned"
  # judged on the last window only: an early good stretch does not count
  fell = [(s, 20.0 if s < 60 else 12.5) for s in range(0, 101, 10)]
  v = collapse.verdict([(s, 20.0 if s < 60 else 12.5) for s in range(0, 201, 10)], 12.0, **JUDGE)
  assert v["window"] == [160, 200]
  assert collapse.verdict(fell, 12.0, **JUDGE)["verdict"] == "collapsed"
  # too short to judge, nothing logged, no images: unchecked
  assert collapse.verdict(flat[:1], 12.0, **JUDGE)["verdict"] == "unchecked"
  assert collapse.verdict([], 12.0, **JUDGE)["verdict"] == "unchecked"
  assert collapse.verdict(flat, None, **JUDGE)["verdict"] == "unchecked"


def _dead_lo(root):
  """A config built to collapse: Lo's density starts at softplus(raw - 30),
  about 1e-13, where its gradient vanishes, so the field stays empty and
  renders the white background whatever it is shown."""
  c = tiny_config()
  c.data.root = root
  c.lo.model.density_bias = -30.0
  c.lo.update(steps=12, log_every=1, eval_every=0)
  c.lo.collapse.after_steps = 10
  return c


def test_a_collapsed_stage_is_not_handed_on(scene_root, tmp_path):
  wd = str(tmp_path / "run")
  with pytest.raises(collapse.Collapsed, match="stage 'lo' collapsed") as e:
    pipeline.run(_dead_lo(scene_root), wd)
  assert e.value.stage == "lo" and e.value.verdict["verdict"] == "collapsed"
  assert e.value.verdict["train_psnr"] < e.value.verdict["constant_psnr"] + 1.0
  with open(os.path.join(wd, "lo", "final", "info.json")) as f:
    assert json.load(f)["learned"]["verdict"] == "collapsed"
  assert not os.path.exists(os.path.join(wd, "ray"))  # nothing was trained on it
  # a later launch of the next stages refuses to restore it
  c = _dead_lo(scene_root)
  c.stages = "ray,hi"
  with pytest.raises(collapse.Collapsed):
    pipeline.run(c, wd)


def test_the_record_says_collapsed(scene_root, tmp_path):
  r = runs.run_method(_dead_lo(scene_root), str(tmp_path / "run"))
  assert r["collapsed"]["stage"] == "lo" and r["learned"] == {"lo": "collapsed"}
  assert r["stages"].keys() == {"lo"} and np.isfinite(r["psnr"])
  assert runs.learned_cell(r) == "collapsed (lo)"


def test_a_stage_that_learns_passes(scene_root, tmp_path):
  c = tiny_config()
  c.data.root = scene_root
  c.stages = "lo"
  c.lo.update(steps=120, log_every=10, eval_every=0, lr_init=1e-2, lr_final=5e-3,
               batch_rays=256, precrop_steps=0)
  c.lo.collapse.after_steps = 100
  info = pipeline.run(c, str(tmp_path / "run"))["lo"]
  v = info["learned"]
  assert v["verdict"] == "learned", v
  assert v["train_psnr"] > v["constant_psnr"] + 1.0


def test_the_command_line_stops_with_one_line(tmp_path):
  wd = tmp_path / "run"
  cmd = [sys.executable, "-m", "halo_jax.cli.train", "--config=configs/default.py",
         f"--workdir={wd}", "--config.stages=lo", "--config.lo.model.density_bias=-30",
         "--config.lo.steps=16", "--config.lo.log_every=1", "--config.lo.collapse.after_steps=10",
         "--config.lo.min_steps=0", "--config.protocol=steps", "--config.budget_s=0", "--config.lo.eval_every_s=0",
         "--config.data.procedural_size=32", "--config.lo.batch_rays=512",
         "--config.lo.microbatches=1", "--config.lo.sampler.num_samples=8",
         "--config.eval.lpips=False", "--config.data.test_views=r_0"]
  res = subprocess.run(cmd, cwd=REPO, capture_output=True, text=True, timeout=300)
  assert res.returncode == 2, res.stderr[-2000:]
  errors = [line for line in res.stderr.splitlines() if line.startswith("error:")]
  assert len(errors) == 1 and "stage 'lo' collapsed" in errors[0]
  assert "Traceback" not in res.stderr


def test_the_comparison_table_flags_a_collapsed_method(tmp_path):
  from halo_jax.cli import compare
  ok = {"psnr": 20.0, "ssim": 0.8, "lpips": 0.2, "wall_s": 10.0, "curve": [[5.0, 18.0]],
        "learned": {"lo": "learned", "ray": "unchecked", "hi": "learned"}}
  dead = dict(ok, psnr=11.0, learned={"lo": "collapsed"},
              collapsed={"stage": "lo", "train_psnr": 11.5, "constant_psnr": 12.0})
  old = {k: v for k, v in ok.items() if k != "learned"}  # a record from before the check
  table = compare.write_report({"halo": ok, "nerf_tuned": dead, "freenerf": old},
                               str(tmp_path), 2)
  rows = {line.split("|")[1].strip(): line.split("|")[-2].strip()
          for line in table.splitlines() if line.startswith("| ") and "method" not in line}
  assert rows == {"halo": "yes", "nerf_tuned": "collapsed (lo)", "freenerf": "-"}
