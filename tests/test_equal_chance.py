"""experiments/bench/equal_chance.py: HALO's margin against the baseline
given the same sampler switch."""
import json
import os

from experiments.bench import budget_studies, equal_chance


def _rec(method, seed, psnr, kind="procedural"):
  return {"method": method, "seed": seed, "psnr": psnr, "config": f"configs/{kind}.py:x",
          "resolved_config": {"data": {"kind": "procedural" if kind == "procedural" else "llff"}}}


def test_rows_pair_the_seeds_all_three_ran():
  runs = {"a": {"halo": [_rec("halo", 0, 22.0), _rec("halo", 1, 24.0)],
                "nerf_tuned": [_rec("nerf_tuned", 0, 23.0)]},
          "b": {"halo": [_rec("halo", 0, 20.0)], "nerf_tuned": [_rec("nerf_tuned", 0, 20.0)]}}
  recs = {("a", "nerf_tuned"): [_rec("nerf_tuned", 0, 21.0), _rec("nerf_tuned", 1, 25.0)],
          ("b", "nerf_tuned"): [_rec("nerf_tuned", 0, 19.0)],
          ("a", budget_studies.BASELINE_TWIN): [_rec("nerf_tuned", 0, 23.5)]}
  # the suite's seed 1 of nerf_tuned not run yet: seed 0 alone; scene b has no twin
  assert equal_chance.rows(runs, recs) == [("a", [0], 22.0, 21.0, 23.0)]
  assert equal_chance.rows(runs, {}) == []


def test_the_section_reports_both_margins_and_the_twins_verdict(tmp_path):
  scenes = [s.name for s in budget_studies.STUDIES["hi_window_960"].scenes]
  runs, twin_psnr = {}, {}
  for i, scene in enumerate(scenes):
    kind = "llff" if scene.startswith("fern") else "procedural"
    twin_psnr[scene] = 21.5 if kind == "procedural" else 20.0   # loses 1 dB on fern
    runs[scene] = {"halo": [_rec("halo", k, 22.0, kind) for k in range(2)],
                   "nerf_tuned": [_rec("nerf_tuned", k, twin_psnr[scene], kind)
                                  for k in range(2)]}
    for variant, p in (("nerf_tuned", 21.0), (budget_studies.BASELINE_TWIN, twin_psnr[scene])):
      for k in range(2):
        path = tmp_path / "ablations" / "hi_window_960" / scene / variant / f"seed{k}.json"
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(json.dumps(dict(_rec("nerf_tuned", k, p, kind), scene=scene,
                                        variant=variant)))
  page = "\n".join(equal_chance.section(runs, str(tmp_path), 960.0))
  assert f"| {scenes[0]} | 0, 1 | 22.00 | 21.00 | 21.50 | +1.00 | +0.50 |" in page
  n = len(scenes)
  assert f"+1.00 dB against nerf_tuned without the switch, {(0.5 * (n - 1) + 2.0) / n:+.2f} dB " \
      "against the suite's" in page
  # the rule per geometry: a gain on every sphere scene, a 1-dB loss on fern
  assert "ndc: fails: fern_4view -1.00; sphere: passes." in page
  assert "adopted" not in page
  # once the baseline's default is the switch, its suite runs are the twin's
  twin_path = f"ablations/hi_window_960/{scenes[0]}/{budget_studies.BASELINE_TWIN}/seed0.json"
  runs[scenes[0]]["nerf_tuned"] = [dict(_rec("nerf_tuned", 0, 21.5), adopted_from={
      "path": twin_path})]
  page = "\n".join(equal_chance.section(runs, str(tmp_path), 960.0))
  assert f"the twin's runs, adopted (its default on {scenes[0]};" in page
  assert equal_chance.section(runs, os.fspath(tmp_path / "none"), 960.0) == []
