"""Few-step smoke runs of every stage, of stage hand-over through the workdir,
of resume, and of the CLI."""
import json
import os
import subprocess
import sys

import imageio.v3 as iio
import numpy as np
import pytest

from conftest import assert_trained, tiny_config
from halo_jax import models, pipeline, registry, stages, validate
from halo_jax.stages import transfer
from halo_jax.configure import finish  # pylint: disable=g-import-not-at-top

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def read_log(workdir):
  with open(os.path.join(workdir, "metrics.jsonl")) as f:
    return [json.loads(line) for line in f]


@pytest.mark.slow
def test_all_stages_then_hi_alone_reuses_earlier_states(config, scene_root, tmp_path):
  config.data.root = scene_root
  config.hi.encoding.with_lo = True
  config.hi.init_from_lo = True
  for name in ("lo", "hi"):
    # 60 steps: enough for the tiny field to fit past the best constant image
    config[name].update(steps=60, log_every=1, checkpoint_every=30, eval_every=30, lr_init=5e-3,
                        lr_final=5e-3)
  config.lo.fg_steps = 4   # the foreground phase's code path, ended in time to judge the fit
  wd = str(tmp_path / "run")
  infos = pipeline.run(finish(config), wd)
  assert list(infos) == ["lo", "ray", "hi"]
  for name in ("lo", "hi"):
    ev = json.load(open(os.path.join(wd, name, "eval", "metrics.json")))
    assert set(ev["per_view"]) == {"r_0", "r_100"}
    assert np.isfinite(ev["ssim"])
    assert os.path.exists(os.path.join(wd, name, "eval", "r_100.png"))
  assert_trained(wd, "lo", config)
  assert_trained(wd, "hi", config)
  # Hi starts as Lo's exact copy and trains on: it ends no worse than Lo held out
  assert infos["hi"]["eval"]["psnr"] > infos["lo"]["eval"]["psnr"] - 0.5
  log = read_log(wd)
  assert {r["stage"] for r in log} == {"lo", "ray", "hi"}
  assert any(r.get("heldout") and r["stage"] == "hi" for r in log)
  assert all(r["skipped"] == 0 for r in log if "skipped" in r)
  # Curves of a pipeline line up: hi's clock starts where lo + ray stopped.
  assert min(r["wall_s"] for r in log if r["stage"] == "hi") > max(
      r["wall_s"] for r in log if r["stage"] == "lo")
  # The orbit renderer reads the finished Hi stage (and its ray field).
  res = subprocess.run([sys.executable, "-m", "halo_jax.cli.render", f"--workdir={wd}", "--frames=2"],
                       cwd=REPO, capture_output=True, text=True, timeout=300)
  assert res.returncode == 0, res.stderr[-3000:]
  frame = iio.imread(os.path.join(wd, "render", "hi_orbit_color_frame0.png"))
  assert frame.shape == (32, 32, 3)
  # A second launch of hi alone reads lo and ray from the workdir and trains
  # more steps from hi's checkpoint.
  config.stages = "hi"
  config.hi.steps = 62
  infos = pipeline.run(finish(config), wd)
  assert list(infos) == ["hi"] and infos["hi"]["step"] == 62


@pytest.mark.slow
def test_nerf_baseline_needs_no_earlier_stage(scene_root, tmp_path):
  from halo_jax import methods
  config = tiny_config(method="")
  config.data.root = scene_root
  config.baseline.num_samples = 8
  config = methods.apply(config, "nerf_tuned")
  config.hi.sampler.kind = "hierarchical"
  assert pipeline.needed(config) == ("hi",)
  infos = pipeline.run(finish(config), str(tmp_path / "nerf"))
  assert infos["hi"]["step"] == config.hi.steps


def test_missing_earlier_stage_is_a_clear_error(config, scene_root, tmp_path):
  config.data.root = scene_root
  config.stages = "hi"
  with pytest.raises(FileNotFoundError, match="stage 'lo' has not finished"):
    pipeline.run(finish(config), str(tmp_path / "empty"))


def test_min_steps_and_target_rays_are_validated(config):
  config.ray.min_steps = -1
  with pytest.raises(registry.ConfigError, match="ray.min_steps=-1"):
    validate.validate(config)


def test_transfer_from_lo_with_lo_encoding_starts_as_lo():
  import jax
  from halo_jax import models
  lo = models.NeRFMLP(pos_freqs=5, pos_scale=8.0, width=16, depth=4, skips=(2,),
                      use_viewdirs=False)
  hi = models.NeRFMLP(pos_freqs=10, base_freqs=5, base_scale=8.0, width=16, depth=4,
                      skips=(2,), use_viewdirs=False)
  p_lo, p_hi = models.init_nerf(lo, "nerf", 0), models.init_nerf(hi, "nerf", 1)
  p = transfer.transfer_from_lo(p_hi, p_lo, lo_inputs_first=True)
  x = jax.random.normal(jax.random.PRNGKey(2), (50, 3))
  for a, b in zip(lo.apply({"params": p_lo}, x, x), hi.apply({"params": p}, x, x)):
    np.testing.assert_allclose(a, b, rtol=1e-5, atol=1e-6)


def test_transfer_from_lo_keeps_input_layer():
  from halo_jax import models
  lo = models.NeRFMLP(pos_freqs=5, width=16, depth=2, skips=(), use_viewdirs=False)
  hi = models.NeRFMLP(pos_freqs=10, width=16, depth=2, skips=(), use_viewdirs=True)
  p_lo, p_hi = models.init_nerf(lo, "nerf", 0), models.init_nerf(hi, "nerf", 1)
  out = transfer.transfer_from_lo(p_hi, p_lo)
  np.testing.assert_array_equal(out["trunk"]["dense_1"]["kernel"], p_lo["trunk"]["dense_1"]["kernel"])
  np.testing.assert_array_equal(out["trunk"]["dense_0"]["kernel"], p_hi["trunk"]["dense_0"]["kernel"])
  np.testing.assert_array_equal(out["view"]["kernel"], p_hi["view"]["kernel"])
  # Equal widths do not make the input layer transferable: it reads other features.
  same_width = models.NeRFMLP(pos_freqs=5, pos_scale=1.0, width=16, depth=2, skips=(),
                              use_viewdirs=False)
  p_same = models.init_nerf(same_width, "nerf", 3)
  out = transfer.transfer_from_lo(p_same, p_lo)
  np.testing.assert_array_equal(out["trunk"]["dense_0"]["kernel"], p_same["trunk"]["dense_0"]["kernel"])
  np.testing.assert_array_equal(out["trunk"]["dense_1"]["kernel"], p_lo["trunk"]["dense_1"]["kernel"])


@pytest.mark.slow
def test_cli_runs_one_stage(scene_root, tmp_path):
  wd = str(tmp_path / "cli")
  cmd = [sys.executable, "-m", "halo_jax.cli.train", "--config=configs/default.py", f"--workdir={wd}",
         f"--config.data.root={scene_root}", "--config.stages=lo", "--config.lo.steps=3",
         "--config.lo.model.width=16", "--config.lo.model.depth=2", "--config.lo.batch_rays=64",
         "--config.lo.sampler.num_samples=8", "--config.data.factor=2",
         "--config.data.test_views=r_0", "--config.protocol=steps", "--config.budget_s=0",
         "--config.lo.encoding.L=6", "--config.lo.encoding.scale=16"]
  res = subprocess.run(cmd, cwd=REPO, capture_output=True, text=True, timeout=300)
  assert res.returncode == 0, res.stderr[-3000:]
  assert "lo" in res.stdout and "PSNR" in res.stdout
  saved = json.load(open(os.path.join(wd, "lo", "final", "config.json")))
  assert (saved["lo"]["encoding"]["L"], saved["lo"]["encoding"]["scale"]) == (6, 16.0)
