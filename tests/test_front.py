"""The error-against-time front: snapshots at training times, scored after training."""
import json
import os
import shutil

import numpy as np
import pytest

from conftest import pipeline_config
from halo_jax import pipeline
from experiments.bench import front_scores as front
from halo_jax.registry import ConfigError
from halo_jax.stages import snapshots
from halo_jax import validate
from halo_jax.configure import finish  # pylint: disable=g-import-not-at-top


def test_snapshots_are_owed_once_and_again_after_a_resume(tmp_path):
  wd = str(tmp_path)
  s = snapshots.Snapshots(wd, "hi", (1.0, 2.0, 3.0), start_step=0, start_total_s=0.5)
  assert s.due(0.9) == [] and s.due(2.5) == [1.0, 2.0]
  s.save(5, {"w": np.ones(3, np.float32)}, 2.5, [1.0, 2.0])   # one step crossed two times
  assert s.due(2.9) == []
  s.save(9, {"w": np.full(3, 2.0, np.float32)}, 3.1, [3.0])
  assert [(p["at_s"], p["step"]) for p in snapshots.read_index(wd, "hi")] == [
      (1.0, 5), (2.0, 5), (3.0, 9)]
  like = {"w": np.zeros(3, np.float32)}
  np.testing.assert_array_equal(snapshots.load_params(wd, "hi", 9, like)["w"], [2.0] * 3)
  # resumed from a checkpoint at step 7 (2.8 s): the point saved after it is
  # owed again, those before it are kept
  r = snapshots.Snapshots(wd, "hi", (1.0, 2.0, 3.0), start_step=7, start_total_s=2.8)
  assert r.pending == [3.0] and [p["at_s"] for p in r.points] == [1.0, 2.0]
  # a fresh stage owes every time it is given, even one its set-up outlasted
  fresh = snapshots.Snapshots(str(tmp_path / "other"), "hi", (1.0, 2.0), start_step=0,
                              start_total_s=1.5)
  assert fresh.pending == [1.0, 2.0]


def test_front_times_must_be_positive_and_increasing(config):
  config.eval.front_s = (30.0, 15.0)
  with pytest.raises(ConfigError, match="eval.front_s"):
    validate.validate(config)
  config.eval.front_s = (0.0, 15.0)
  with pytest.raises(ConfigError, match="eval.front_s"):
    validate.validate(config)


def _info(wd, name):
  with open(os.path.join(wd, name, "final", "info.json")) as f:
    return json.load(f)


@pytest.mark.slow
def test_each_point_scores_what_a_run_stopped_there_scores(scene_root, tmp_path):
  """HALO, stage by stage, with one front time just after each stage starts:
  Lo's and Hi's points are their states after their first step, and Hi's
  scores what a run stopped at that step scores itself; the ray field's
  point is Lo's final state (what the method outputs while it trains)."""
  c = pipeline_config(scene_root, steps=4)
  c.eval.lpips = False
  wd = str(tmp_path / "run")
  eps = 1e-9
  c.eval.front_s, c.stages = (eps,), "lo"
  pipeline.run(finish(c), wd)
  after_lo = _info(wd, "lo")["cumulative_wall_s"]
  c.eval.front_s, c.stages = (eps, after_lo + eps), "ray"
  pipeline.run(finish(c), wd)
  after_ray = _info(wd, "ray")["cumulative_wall_s"]
  shutil.copytree(wd, str(tmp_path / "stopped"))  # Lo and the ray field, finished
  c.eval.front_s, c.stages = (eps, after_lo + eps, after_ray + eps), "hi"
  pipeline.run(finish(c), wd)

  points = front.evaluate_front(wd, with_lpips=False)
  assert [(p["stage"], p["step"]) for p in points] == [("lo", 1), ("lo", None), ("hi", 1)]
  assert [p["at_s"] for p in points] == list(c.eval.front_s)
  assert all(p["wall_s"] >= p["at_s"] for p in points)
  assert points[1]["psnr"] == pytest.approx(_info(wd, "lo")["eval"]["psnr"], abs=1e-4)

  hi_stop = pipeline_config(scene_root, steps=4)
  hi_stop.eval.lpips, hi_stop.stages, hi_stop.hi.stop_at_step = False, "hi", 1
  pipeline.run(finish(hi_stop), str(tmp_path / "stopped"))
  assert points[2]["psnr"] == pytest.approx(
      _info(str(tmp_path / "stopped"), "hi")["eval"]["psnr"], abs=1e-4)
  assert points[0]["psnr"] != pytest.approx(points[1]["psnr"], abs=1e-3)  # Lo trained on
