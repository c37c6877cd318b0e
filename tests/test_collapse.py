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
from halo_jax.configure import finish  # pylint: disable=g-import-not-at-top

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


def test_the_boundary_is_the_margin_itself():
  """A median exactly margin_db above the constant learned; a hair under did
  not (sparse's nerf_tuned at seed 1 sat at 17.23 against 17.23)."""
  at = [(s, 17.23) for s in range(10, 101, 10)]
  assert collapse.verdict(at, 16.23, **JUDGE)["verdict"] == "learned"
  under = [(s, 17.23 - 1e-9) for s in range(10, 101, 10)]
  assert collapse.verdict(under, 16.23, **JUDGE)["verdict"] == "collapsed"
  assert collapse.heldout(16.23 + 1.0, 16.23, 1.0)["verdict"] == "learned"
  assert collapse.heldout(16.23 + 1.0 - 1e-9, 16.23, 1.0)["verdict"] == "collapsed"


# The CPU terms where the old verdict misjudged: log every 50 steps, a
# 300-step stage whose first 200 steps draw the centre crop, judged after
# step 200 over its last 20%.
CPU_JUDGE = dict(margin_db=1.0, after_steps=200, window=0.2)


def test_a_short_stage_past_its_crop_is_unjudged_not_learned():
  """Two records after the crop cannot be told from noise: 'unjudged'. The
  old fallback reached back to step 100's crop batches for its 5 records."""
  records = [(s, 30.0) for s in range(50, 301, 50)]
  v = collapse.verdict(records, 12.0, judged_from=200, **CPU_JUDGE)
  assert v["verdict"] == "unjudged" and v["window"] == [250, 300]
  # a stage stopped before after_steps stays unchecked, as before
  assert collapse.verdict(records[:3], 12.0, judged_from=200, **CPU_JUDGE)["verdict"] == \
      "unchecked"


def test_crop_batches_are_not_judged():
  """A stage whose crop batches (the object, harder than the mostly white
  whole images) score under the constant of whole images, and which fits
  the whole images after the crop, learned: its crop records are not read.
  Judged with them, it would be called collapsed."""
  crop = [(s, 9.0) for s in range(10, 201, 10)]          # the object only
  whole = [(s, 11.0 + 0.1 * (s - 200)) for s in range(210, 301, 10)]
  records = crop + whole
  assert collapse.verdict(records, 12.0, judged_from=200, **CPU_JUDGE)["verdict"] == "learned"
  # what the check said when it read the crop's records too (5-record fallback)
  short = crop + whole[:2]
  assert collapse.verdict(short, 12.0, judged_from=0, **CPU_JUDGE)["verdict"] == "collapsed"
  assert collapse.verdict(short, 12.0, judged_from=200, **CPU_JUDGE)["verdict"] == "unjudged"


def test_a_stage_that_learns_late_after_its_crop_learned():
  """thin's Lo: at the constant's level for its first 350 steps, then
  rising (14.0 at 400, 17.4 at 450): learned at 500 steps, judged on
  whole-image batches only."""
  records = [(s, 12.2) for s in range(50, 351, 50)] + [(400, 14.0), (450, 17.4), (500, 18.5)]
  records = sorted(records + [(s, 12.3) for s in (225, 275, 325)])
  v = collapse.verdict(records, 12.26, judged_from=200, **CPU_JUDGE)
  assert v["window"] == [325, 500] and v["verdict"] == "learned", v


def test_a_field_that_renders_background_is_flagged_on_heldout_views():
  """sparse: two small objects on white. nerf_tuned fitted its training rays
  and rendered pure background on the validation views. Whatever the
  objects, pure white cannot beat the views' mean colour, so it is flagged;
  a render close to the views learned."""
  rng = np.random.default_rng(0)
  views = np.ones((4, 40, 40, 3))
  views[:, 10:14, 10:16] = rng.uniform(0, 0.5, (4, 4, 6, 3))   # ~5% of each frame
  views[:, 25:28, 20:24] = rng.uniform(0, 0.5, (4, 3, 4, 3))
  constant = collapse.constant_psnr(views)

  def psnr(render):
    return -10 * np.log10(((render - views) ** 2).mean())
  white = psnr(np.ones_like(views))
  assert white < constant
  assert collapse.heldout(white, constant, 1.0)["verdict"] == "collapsed"
  close = np.clip(views + rng.normal(0, 0.02, views.shape), 0, 1)
  assert collapse.heldout(psnr(close), constant, 1.0)["verdict"] == "learned"


def test_the_ray_fields_baseline_is_the_mixtures_variance():
  """targets_baseline against the batch mixture written out: each source
  repeated in proportion to its rays per batch, the variance of d / far plus
  that of acc, in dB."""
  rng = np.random.default_rng(1)
  d1, a1 = rng.uniform(2, 6, 30), rng.uniform(0, 1, 30)
  d2, a2 = rng.uniform(1, 3, 20), (rng.uniform(size=20) > 0.5).astype(float)
  far, w1, w2 = 6.0, 3, 1    # 3 training rays per random ray
  b = collapse.targets_baseline([d1, d2], [a1, a2], far, [w1, w2])
  d = np.concatenate([np.repeat(d1, w1 * len(d2)), np.repeat(d2, w2 * len(d1))]) / far
  a = np.concatenate([np.repeat(a1, w1 * len(d2)), np.repeat(a2, w2 * len(d1))])
  assert b.db == pytest.approx(-10 * np.log10(d.var() + a.var()), rel=1e-12)
  assert b.key == "loss" and not b.in_db
  # the verdict reads L_ray in dB: a loss a tenth of the constant's learned
  mse = 10 ** (-b.db / 10)
  records = [(s, mse / 10) for s in range(10, 101, 10)]
  assert collapse.judge(records, b, **JUDGE)["verdict"] == "learned"
  records = [(s, mse) for s in range(10, 101, 10)]
  v = collapse.judge(records, b, **JUDGE)
  assert v["verdict"] == "collapsed" and "L_ray" in v["figure"]


def _dead_lo(root):
  """A config built to collapse: Lo's density starts at softplus(raw - 30),
  about 1e-13, where its gradient vanishes, so the field stays empty and
  renders the white background whatever it is shown."""
  c = tiny_config()
  c.data.root = root
  c.lo.model.density_bias = -30.0
  c.lo.update(steps=12, log_every=1, eval_every=0, precrop_steps=0, fg_steps=0)
  c.lo.collapse.after_steps = 10
  return c


def test_a_collapsed_stage_is_not_handed_on(scene_root, tmp_path):
  wd = str(tmp_path / "run")
  with pytest.raises(collapse.Collapsed, match="stage 'lo' collapsed") as e:
    pipeline.run(finish(_dead_lo(scene_root)), wd)
  assert e.value.stage == "lo" and e.value.verdict["verdict"] == "collapsed"
  assert e.value.verdict["train_psnr"] < e.value.verdict["constant_psnr"] + 1.0
  with open(os.path.join(wd, "lo", "final", "info.json")) as f:
    assert json.load(f)["learned"]["verdict"] == "collapsed"
  assert not os.path.exists(os.path.join(wd, "ray"))  # nothing was trained on it
  # a later launch of the next stages refuses to restore it
  c = _dead_lo(scene_root)
  c.stages = "ray,hi"
  with pytest.raises(collapse.Collapsed):
    pipeline.run(finish(c), wd)


def test_the_record_says_collapsed(scene_root, tmp_path):
  r = runs.run_method(finish(_dead_lo(scene_root)), str(tmp_path / "run"))
  assert r["collapsed"]["stage"] == "lo" and r["learned"] == {"lo": "collapsed"}
  assert r["stages"].keys() == {"lo"} and np.isfinite(r["psnr"])
  assert runs.learned_cell(r) == "collapsed (lo)"


def test_a_stage_that_learns_passes(scene_root, tmp_path):
  c = tiny_config()
  c.data.root = scene_root
  c.stages = "lo,ray"
  c.lo.update(steps=120, log_every=10, eval_every=0, lr_init=1e-2, lr_final=5e-3,
               batch_rays=256, precrop_steps=0, fg_steps=0)
  c.lo.collapse.after_steps = 100
  c.ray.update(steps=200, log_every=10, lr_init=5e-3, batch_rays=256)
  c.ray.collapse.after_steps = 50
  infos = pipeline.run(finish(c), str(tmp_path / "run"))
  v = infos["lo"]["learned"]
  assert v["verdict"] == "learned", v
  assert v["train_psnr"] > v["constant_psnr"] + 1.0
  assert infos["lo"]["heldout_learned"]["verdict"] == "learned"
  # the ray field is judged too: its L_ray against the targets' constant
  v = infos["ray"]["learned"]
  assert v["verdict"] == "learned" and "L_ray" in v["figure"], v


def test_the_command_line_stops_with_one_line(tmp_path):
  wd = tmp_path / "run"
  cmd = [sys.executable, "-m", "halo_jax.cli.train", "--config=configs/default.py",
         f"--workdir={wd}", "--config.stages=lo", "--config.lo.model.density_bias=-30",
         "--config.lo.steps=16", "--config.lo.log_every=1", "--config.lo.collapse.after_steps=10",
         "--config.lo.min_steps=0", "--config.lo.fg_steps=0", "--config.lo.precrop_steps=0", "--config.protocol=steps", "--config.budget_s=0", "--config.lo.eval_every_s=0",
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
