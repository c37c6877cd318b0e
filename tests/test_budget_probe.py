"""The budget study's probe (experiments/bench/budget_probe.py): its window
figures against a hand count, L_empty's share against its arithmetic, and,
end to end on the smoke suite, its re-renders against the runs' own scores."""
import json
import os

import ml_collections
import numpy as np
import pytest

from experiments.bench import budget_probe


def test_window_facts_count_what_the_window_holds():
  # near 2, far 6, window 0.25: half a window is 1; the third ray's window is
  # clipped at far to [4.5, 6]
  cfg = ml_collections.ConfigDict(dict(window=0.25, num_samples=8, near_only=False))
  depth = np.array([3.0, 3.0, 5.5, 4.0])
  own = np.array([3.5, 4.5, 6.0, 4.0])        # the second misses its window [2, 4]
  other = np.array([2.1, 3.0, 4.0, 4.0])      # the third misses [4.5, 6]
  opaque = np.array([True, True, True, False])
  sq_err = np.array([1.0, 2.0, 3.0, 4.0])
  f = budget_probe.window_facts(depth, cfg, 2.0, 6.0, own, other, opaque, sq_err)
  assert f["mean_window_share"] == pytest.approx((2 + 2 + 1.5 + 2) / 4 / 4)
  assert f["opaque_share"] == pytest.approx(0.75)
  assert f["hi_surface_in_window"] == pytest.approx(2 / 3)
  assert f["baseline_surface_in_window"] == pytest.approx(2 / 3)
  assert f["median_to_hi_surface"] == pytest.approx(0.5 / 4)
  assert f["median_to_baseline_surface"] == pytest.approx(0.9 / 4)
  assert f["error_share_where_window_misses"] == pytest.approx(2 / 10)
  assert f["ray_share_where_window_misses"] == pytest.approx(1 / 4)


def test_empty_share_is_the_weighted_term_over_the_loss(tmp_path):
  rows = [{"stage": "lo", "step": 1, "loss": 1.0}]
  rows += [{"stage": "hi", "step": i, "loss": 0.01, "empty": 1e-3 * i} for i in range(1, 9)]
  rows.append({"stage": "hi", "step": 8, "heldout": True, "psnr": 20.0})
  with open(tmp_path / "metrics.jsonl", "w") as f:
    f.write("\n".join(json.dumps(r) for r in rows))
  share = budget_probe.empty_share(str(tmp_path), 0.1)
  # the first and last quarter of the 8 logged Hi rows: 2 rows each
  assert share["first"] == pytest.approx(0.1 * np.mean([1e-3, 2e-3]) / 0.01)
  assert share["last"] == pytest.approx(0.1 * np.mean([7e-3, 8e-3]) / 0.01)
  assert budget_probe.empty_share(str(tmp_path), 0.0) is None


@pytest.mark.slow
def test_probe_renders_the_runs_as_they_scored_themselves(tmp_path):
  from experiments.bench import benchmark, suites
  results, scratch = str(tmp_path / "results"), str(tmp_path / "scratch")
  scene = suites.SMOKE.scenes[0]
  assert budget_probe.probe_run("smoke", "budget", scene, 0, results, [scratch]) is None
  for method in ("halo", "nerf_tuned"):
    benchmark.run_one("smoke", suites.SMOKE, scene, method, 0, "budget", results, scratch)
  out = budget_probe.probe_run("smoke", "budget", scene, 0, results, [scratch])
  with open(budget_probe.probe_path(results, "smoke", scene.name, 0)) as f:
    assert json.load(f)["psnr"] == out["psnr"]
  # the probe's renders as trained are the runs' own final evaluations
  for key, method in (("own", "halo"), ("nerf_tuned", "nerf_tuned")):
    assert out["psnr"][key] == pytest.approx(out["record_psnr"][method], abs=1e-3)
  assert out["hi_sampler"] == {"kind": "depth_guided", "num_samples": 8}
  # smoke: Hi's 8 guided samples, nerf_tuned's 8 stratified: every change is one thing
  changes = {(c["field"], c["change"], c["from"], c["to"]) for c in out["one_at_a_time"]}
  assert {("halo", "kind", k, "own") for k in ("stratified_own_count", "baseline_sampler")} & changes
  assert ("halo", "count", "own", "own_twice_samples") in changes
  assert ("nerf_tuned", "count", "nerf_tuned", "nerf_tuned_twice_samples") in changes
  for c in out["one_at_a_time"]:
    assert c["delta_db"] == pytest.approx(out["psnr"][c["to"]] - out["psnr"][c["from"]])
  g = out["guide"]
  assert 0 < g["mean_window_share"] <= 1 and 0 <= g["hi_surface_in_window"] <= 1
  bg = out["background_acc"]
  assert 0 < bg["pixel_share"] < 1 and 0 <= bg["lo"] <= 1 and 0 <= bg["lo_sees_empty"] <= 1
  # a workdir that is not the record's run is refused
  path = benchmark.result_path(results, "smoke", "budget", scene, "halo", 0)
  with open(path) as f:
    record = json.load(f)
  record["stages"]["hi"]["step"] += 1
  with open(path, "w") as f:
    json.dump(record, f)
  with pytest.raises(ValueError, match="not that run's workdir"):
    budget_probe.probe_run("smoke", "budget", scene, 0, results, [scratch])
  assert os.path.exists(budget_probe.probe_path(results, "smoke", scene.name, 0))


def test_one_at_a_time_pairs_change_one_thing():
  labels = {"own": ("halo", "depth_guided", 32), "own_twice_samples": ("halo", "depth_guided", 64),
            "stratified_own_count": ("halo", "stratified", 32),
            "baseline_sampler": ("halo", "stratified", 64),
            "twice_baseline_samples": ("halo", "stratified", 128),
            "nerf_tuned": ("nerf_tuned", "stratified", 64),
            "nerf_tuned_twice_samples": ("nerf_tuned", "stratified", 128)}
  psnr = {k: float(i) for i, k in enumerate(labels)}
  got = {(c["change"], c["from"], c["to"]) for c in budget_probe.one_at_a_time(labels, psnr)}
  assert got == {
      ("kind", "stratified_own_count", "own"), ("kind", "baseline_sampler", "own_twice_samples"),
      ("count", "own", "own_twice_samples"), ("count", "stratified_own_count", "baseline_sampler"),
      ("count", "baseline_sampler", "twice_baseline_samples"),
      ("count", "nerf_tuned", "nerf_tuned_twice_samples")}


def test_probe_rays_take_a_regular_grid_within_the_ray_budget():
  class FakeViews:  # 3 views of 10 x 8 pixels
    images = np.arange(3 * 10 * 8 * 3, dtype=np.float32).reshape(3, 10, 8, 3)

    def rays(self):
      return self.images, self.images + 1

    def ray_times(self):
      return None

  o, d, t, gt, stride = budget_probe.probe_rays(FakeViews(), max_rays=240)
  assert stride == 1 and o.shape == (3, 10, 8, 3) and t is None
  o, d, t, gt, stride = budget_probe.probe_rays(FakeViews(), max_rays=60)
  assert stride == 2 and gt.shape == (3, 5, 4, 3)       # 60 rays
  np.testing.assert_array_equal(gt, FakeViews.images[:, ::2, ::2])
  np.testing.assert_array_equal(d, gt + 1)
  assert budget_probe.probe_rays(FakeViews(), max_rays=59)[4] == 3


def test_shortfalls_name_each_scene_and_budget_with_the_nearest_probe():
  """A line for every (scene, budget) where halo trails or Hi ends under Lo,
  read from that budget's probe, or the nearest one's where it has none."""
  from experiments.bench import probe_report, suites
  scene, other = suites.BUDGET_SCENES[0], suites.BUDGET_SCENES[1]
  figures = {(60, scene): (-0.4, 0.3), (240, scene): (0.2, -0.1), (960, scene): (0.5, 0.2),
             (60, other): (0.1, 0.1), (240, other): (0.1, 0.1), (960, other): (0.1, 0.1)}
  by_budget = {b: {s: (b, s) for (bb, s) in figures if bb == b} for b in (60, 240, 960)}
  lead = lambda runs: figures[runs][0] if runs else None
  gain = lambda runs: figures[runs][1] if runs else None
  reading = {(960, scene): "Reading: far.", (60, scene): "Reading: near."}
  lines = probe_report.shortfalls({k: [] for k in reading}, by_budget, gain, lead, reading)
  body = [l for l in lines if l.startswith("- ")]
  assert len(body) == 2 and all(scene in l for l in body)
  assert "at 60 s**: halo − nerf_tuned -0.40 dB. Reading: near." in body[0]
  assert "Hi − Lo -0.10 dB. Not probed at 240 s; the 60-s probe's reading: near." in body[1]


def test_a_probe_of_a_run_trained_again_is_named_with_both_scores():
  from experiments.bench import probe_report
  probe = {"seed": 0, "record_psnr": {"halo": 17.0, "nerf_tuned": 18.64}}
  by_budget = {960: {"dnerf_lego": {"halo": [{"seed": 0, "psnr": 17.0}],
                                    "nerf_tuned": [{"seed": 0, "psnr": 17.457},
                                                   {"seed": 1, "psnr": 18.64}]}}}
  lines = probe_report.retrained_lines({(960, "dnerf_lego"): [probe]}, by_budget)
  assert len(lines) == 2 and "nerf_tuned seed 0: 18.64 against 17.46 dB" in lines[0]
  assert "halo seed" not in lines[0]
  probe["record_psnr"]["nerf_tuned"] = 17.457
  assert probe_report.retrained_lines({(960, "dnerf_lego"): [probe]}, by_budget) == []


def test_a_run_past_its_switch_is_probed_from_the_sampler_it_was_scored_with():
  import types
  from conftest import tiny_config
  from halo_jax.configure import finish
  c = tiny_config()
  c.hi.sampler.update(switch_step=4, switch_samples=16)
  c = finish(c)

  def run(step):
    return types.SimpleNamespace(config=c, states={"hi": types.SimpleNamespace(step=step)})

  past = budget_probe.as_scored(run(5)).hi.sampler
  assert (past.num_samples, past.switch_step) == (16, 0)  # a probe's fields now replace it
  assert budget_probe.as_scored(run(4)) is c               # short of it: as configured


def test_the_other_scenes_probes_name_a_shortfall_and_the_dense_count(tmp_path, monkeypatch):
  from experiments.bench import probe_report
  psnr = {"own": 23.0, "own_twice_samples": 23.2, "stratified_own_count": 22.9,
          "baseline_sampler": 23.9, "twice_baseline_samples": 24.0, "nerf_tuned": 23.9,
          "nerf_tuned_twice_samples": 24.05}
  probe = {"seed": 0, "psnr": psnr, "record_psnr": {"halo": 24.0, "nerf_tuned": 24.1},
           "samplers": {"baseline_sampler": {"kind": "stratified", "num_samples": 128}},
           "hi_sampler": {"kind": "depth_guided", "num_samples": 64}}
  monkeypatch.setattr(probe_report, "probes",
                      lambda results, scenes=None: {(960.0, "spheres"): [probe]})
  lines = "\n".join(probe_report.other_scenes_section(str(tmp_path), {"spheres": -0.10}))
  assert "- **spheres at 960 s.** halo − nerf_tuned -0.10 dB: a goal's shortfall." in lines
  assert "a goal's shortfall" not in "\n".join(probe_report.other_scenes_section(str(tmp_path)))
  from experiments.bench import suites  # pylint: disable=import-outside-toplevel
  spheres = tuple(s for s in suites.VALIDATION_SCENES if s.name == "spheres")
  dense = "\n".join(probe_report.dense_eval_section(str(tmp_path), spheres, 960.0))
  assert "| spheres (0) | 23.00 | 23.90 (128) | 23.90 | 24.05 | -0.90 |" in dense
