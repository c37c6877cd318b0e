"""experiments/report.py: tables and README block from result files, checked by hand-computed numbers."""
import json
import os

import numpy as np
import pytest

from experiments.bench import fronts_report, report, suite_tables


def _record(psnr, curve, steps=100):
  return {"psnr": psnr, "ssim": 0.8, "lpips": 0.2, "curve": curve, "num_views": 3,
          "config": "configs/x.py:y", "budget_s": 10.0, "stages": {"hi": {"step": steps}},
          "provenance": {"git": {"commit": "abcdef0123", "dirty": False},
                         "device": {"kind": "cpu", "count": 1},
                         "cpu": {"model": "M", "cores_used": 1}, "matmul_peak_gflops": 90.0,
                         "versions": {"jax": "0", "flax": "0"}}}


def _write(root, method, seed, rec, scene="s1"):
  path = os.path.join(root, "cpu", "budget", scene, method, f"seed{seed}.json")
  os.makedirs(os.path.dirname(path), exist_ok=True)
  with open(path, "w") as f:
    json.dump(rec, f)


def test_tables_and_readme_block(tmp_path):
  root, docs = str(tmp_path / "results"), str(tmp_path / "docs")
  os.makedirs(docs)
  _write(root, "nerf_tuned", 0, _record(20.0, [[1, 15.0], [5, 19.0]]))
  _write(root, "nerf_tuned", 1, _record(22.0, [[1, 16.0], [5, 21.0]]))
  _write(root, "halo", 0, _record(23.0, [[1, 18.0], [5, 22.0]]))
  suites = report.load(root)
  by = suites[("cpu", "budget")]["s1"]
  table = report.scene_table(by)
  std = np.std([20.0, 22.0], ddof=1)
  assert f"| nerf_tuned | 2 | 21.00 ± {std:.2f} |" in table
  assert "| halo | 1 | 23.00 |" in table and "| +2.00 |" in table
  # common level: the median of the run peaks (19, 21, 22) less 0.5; a seed of
  # nerf_tuned never reaches 20.5, halo does at 5 s
  assert "s to 20.5 dB" in table
  assert "| 100 | - |" in table and "| 100 | 5 |" in table
  assert suite_tables.seconds_to_reach(by["halo"], 20.5) == 5.0
  assert suite_tables.seconds_to_reach(by["halo"], 17.0) == 1.0
  grid = np.array([0.0, 1.0, 3.0, 5.0, 6.0])
  np.testing.assert_array_equal(suite_tables.curve_on_grid(by["halo"], grid),
                                [[np.nan, 18.0, 20.0, 22.0, np.nan]])
  name = report.write_suite("cpu", "budget", suites[("cpu", "budget")], docs)
  assert os.path.exists(os.path.join(docs, f"{name}_s1.png"))
  readme = tmp_path / "README.md"
  readme.write_text("top\n<!-- results:begin -->\nold\n<!-- results:end -->\nbottom\n")
  assert report.update_readme(str(readme), report.readme_block(suites))
  text = readme.read_text()
  assert "old" not in text and "| [cpu/budget](docs/results/cpu_budget.md) | s1 |" in text
  assert text.startswith("top\n") and text.endswith("bottom\n")
  # the headline is computed from the files: 23 against the mean of 20 and 22
  assert ("halo against nerf_tuned on the 1 scenes both ran (1-2 seeds each): +2.00 dB on "
          "average (each scene weighs the same), ahead on 1 of 1.") in text
  _write(root, "halo", 0, _record(20.5, [[1, 18.0]]), scene="s2")
  _write(root, "nerf_tuned", 0, _record(21.0, [[1, 18.0]]), scene="s2")
  line = report.headline(report.load(root)[("cpu", "budget")])
  assert ("+0.75 dB on average (each scene weighs the same), ahead on 1 of 2; behind or level "
          "on s2 (-0.50).") in line
  assert "No run of either method collapsed." in line
  # a collapsed baseline run is named, and the mean is given without its scene
  r = _record(10.0, [[1, 10.0]])
  r["heldout_learned"] = {"hi": "collapsed"}
  _write(root, "nerf_tuned", 0, r, scene="s3")
  _write(root, "halo", 0, _record(20.0, [[1, 20.0]]), scene="s3")
  line = report.headline(report.load(root)[("cpu", "budget")])
  assert "+3.83 dB on average" in line
  assert ("The mean pools scenes where a run collapsed: s3 (nerf_tuned); without them, "
          "+0.75 dB over the other 2, ahead on 1 of them.") in line
  table = suite_tables.over_scenes_table(report.load(root)[("cpu", "budget")])
  assert "| halo | 3 | 21.17 | +3.83 | 2 of 3 | +0.75 (s3) |" in table


def test_a_suite_pools_one_fingerprint_per_method_and_lists_the_rest(tmp_path, monkeypatch):
  root, docs = str(tmp_path / "results"), str(tmp_path / "docs")
  os.makedirs(docs)
  trees = {"new": "a" * 12, "old": "b" * 12, "unmeasured": "c" * 12}

  def rec(psnr, tree, dirty=False):
    r = _record(psnr, [[1, psnr]])
    r["provenance"]["git"].update(code_tree=trees[tree], code_dirty=dirty, dirty=dirty)
    return r
  for seed, (p, tree) in enumerate([(23.0, "new"), (24.0, "new"), (30.0, "old")]):
    r = rec(p, tree)
    r["method"] = "halo"
    r["stages"]["hi"]["wall_s"] = 10.0 * (seed + 1)  # 100 steps: 10, 5 and 3.3 steps/s
    _write(root, "halo", seed, r)
  for seed, (p, tree, dirty) in enumerate([(21.0, "new", False), (40.0, "unmeasured", False),
                                           (50.0, "new", True)]):
    r = rec(p, tree, dirty)
    r.update(method="nerf_tuned", seed=seed)
    _write(root, "nerf_tuned", seed, r)
  table = {trees["new"]: {"methods": {"halo": "fp_halo_new", "nerf_tuned": "fp_nt"}},
           trees["old"]: {"methods": {"halo": "fp_halo_old"}}}
  table[trees["new"]]["commit"] = "1234567890"
  table["d" * 12] = {"commit": "fedcba9876", "commit_time": "2026-01-02T00:00:00+00:00",
                     "methods": {"halo": "fp_halo_new", "nerf_tuned": "fp_other"}}
  scenes, versions = report.pool(report.load(root)[("cpu", "budget")], table)
  assert [r["psnr"] for r in scenes["s1"]["halo"]] == [23.0, 24.0]
  assert [r["psnr"] for r in scenes["s1"]["nerf_tuned"]] == [21.0]
  assert versions["halo"]["fingerprint"] == "fp_halo_new" and versions["halo"]["current"]
  assert not versions["nerf_tuned"]["current"]
  why = sorted(w for _, _, w in versions["nerf_tuned"]["aside"])
  assert why == ["modified tree", "unmeasured"]
  # nerf_tuned's pooled runs are not the newest measured code's: no figures
  line = report.headline(scenes, versions=versions)
  assert line.startswith("no figures: the runs of nerf_tuned are not of the newest measured")
  versions["nerf_tuned"]["current"] = True
  line = report.headline(scenes, versions=versions)
  assert "+2.50 dB on average" in line  # 23.5 - 21: the set-aside 30, 40 and 50 are not pooled
  assert "Per scene kind (scenes): x +2.50 (1)." in line
  # current: what the newest measured commit (fedcba9, by commit time) computes
  assert ("halo fp_halo_new (2 runs, 1 set aside; the newest measured code, fedcba9, computes "
          "the same)") in line
  assert ("nerf_tuned fp_nt (1 runs, 2 set aside; the newest measured code, fedcba9, computes "
          "the same)") in line
  page = "\n".join(report.version_lines(versions))
  # the pooled runs' median final-stage rate: (10 + 5) / 2
  assert "| halo | fp_halo_new | 2 | yes | 7.50 | 1 (fp_halo_old) |" in page
  assert "| s1 | nerf_tuned | 1 | abcdef0 | unmeasured | 40.00 |" in page


def test_summary_table_names_scene_changes(tmp_path):
  root = str(tmp_path / "results")
  rec = _record(12.0, [[1, 10.0]])
  rec["scene_overrides"] = [["hi.density_noise", 1.0]]
  _write(root, "nerf_paper", 0, rec, scene="v+noise")
  _write(root, "nerf_paper", 0, _record(10.0, [[1, 9.0]]), scene="v")
  _write(root, "nerf_paper", 1, _record(11.0, [[1, 9.0]]), scene="v")
  table = report.summary_table(report.load(root)[("cpu", "budget")])
  std = np.std([10.0, 11.0], ddof=1)
  assert f"| v | none | 10.50 ± {std:.2f} |" in table
  assert "| v+noise | `hi.density_noise=1.0` | 12.00 |" in table


def test_goals_met_only_at_the_stated_margin(tmp_path):
  root = str(tmp_path / "results")
  failing = _record(20.0, [[1, 18.0], [2, 21.0], [3, 20.0]])  # ends 1 dB below its peak
  failing["config"] = "configs/dnerf.py:a_cpu"
  halo_dyn = _record(20.49, [[1, 19.0]])
  halo_dyn["config"] = failing["config"]
  _write(root, "nerf_tuned", 0, failing, scene="a")
  _write(root, "halo", 0, halo_dyn, scene="a")
  _write(root, "nerf_tuned", 0, _record(20.0, [[1, 18.0], [2, 20.0]]), scene="b")
  _write(root, "halo", 0, _record(21.0, [[1, 19.0]]), scene="b")
  _write(root, "freenerf", 0, _record(22.0, [[1, 19.0]]), scene="b")
  scenes = report.load(root)[("cpu", "budget")]
  assert suite_tables.curve_drop(scenes["a"]["nerf_tuned"]) == 1.0
  by_kind, per_scene = report.claims(scenes)
  # dnerf: +0.49 dB, short of the +0.5 stated for the kind: not met, however
  # close; x (configs/x.py) has no stated goal, so +1 dB is not judged
  assert "| dnerf | a | nerf_tuned | +0.49 | a | +0.5 | **no** |" in by_kind
  assert "| x | b | nerf_tuned | +1.00 | none | - | no goal stated |" in by_kind
  assert "| b | freenerf | -1.00 | 1 / 1 | **halo trails freenerf** |" in per_scene
  assert "| b | nerf_tuned | +1.00 | 1 / 1 | halo ahead |" in per_scene


def test_frequency_calibration_report_from_result_files(tmp_path):
  from experiments.bench import calibrate_frequency  # pylint: disable=g-import-not-at-top
  results, docs = tmp_path / "frequency", str(tmp_path / "docs")
  os.makedirs(results)
  points = [(10, 1.0), (7, 1.0), (5, 1.0), (4, 1.0)]
  for name, crit, psnr in (("a", [0.9, 0.7, 0.5, 0.3], [18, 19, 21, 20]),
                           ("b", [0.8, 0.65, 0.45, 0.3], [18, 19, 22, 20]),
                           ("c", [0.95, 0.75, 0.52, 0.4], [18, 19, 23, 21])):
    grid = [{"L": L, "scale": s, "max_freq": 2.0 ** (L - 1) / s, "criterion": c,
             "criterion_plain": c, "criterion_warped": c / 2, "psnr": p,
             "ssim": 0.5, "shift_px": [1.0, 1.0], "pair_kind": "orbit"}
            for (L, s), c, p in zip(points, crit, psnr)]
    with open(results / f"{name}.json", "w") as f:
      json.dump({"scene": name, "config": "configs/x.py:y", "lo_steps": 10, "hi_freq": 512.0,
                 "hand_set": {"L": 5, "scale": 1.0}, "grid": grid}, f)
  scenes = calibrate_frequency.load_results(str(results))
  text, frozen = calibrate_frequency.report(scenes, docs)
  # every form agrees (warped = plain / 2 scores the same); the first, plain rho, is frozen
  assert not frozen["warp"] and not frozen["relative"] and 0.52 < frozen["threshold"] <= 0.65
  assert "3 of 3 picks within 1 dB" in text and "### Leave-one-out, warped rho" in text
  assert "| c | 0.575 | 5:1 | 23.00 | 5:1 | 23.00 | 0.00 | 5:1 |" in text
  assert os.path.exists(os.path.join(docs, "frequency_a.png"))


def test_by_stage_names_every_run_whose_later_stage_ended_below_an_earlier(tmp_path):
  root = str(tmp_path / "results")
  for seed, (lo, hi) in enumerate(((20.0, 21.0), (22.0, 21.5))):
    rec = _record(hi, [[1, hi]])
    rec["seed"] = seed
    rec["stages"] = {"lo": {"step": 10, "psnr": lo}, "ray": {"step": 5},
                     "hi": {"step": 20, "psnr": hi}}
    _write(root, "halo", seed, rec)
  _write(root, "nerf_tuned", 0, _record(20.0, [[1, 20.0]]))  # one stage: no row
  # a study's files beside the suites' are not read as a suite
  study = os.path.join(root, "ablations", "fog", "s1", "halo", "seed0.json")
  os.makedirs(os.path.dirname(study))
  with open(study, "w") as f:
    json.dump(_record(1.0, [[1, 1.0]]), f)
  suites = report.load(root)
  assert set(suites) == {("cpu", "budget")}
  table = report.stage_table(suites[("cpu", "budget")])
  assert "| s1 | halo | 2 | 21.00 ± 1.41 | 21.25 ± 0.35 | +0.25 | lo 10, ray 5, hi 20 |" in table
  assert "seed1: hi 21.50 < lo 22.00" in table and "seed0" not in table
  assert "nerf_tuned" not in table


def test_by_stage_on_validation_views_reads_the_validation_scores(tmp_path):
  root = str(tmp_path / "results")
  # the test views say Hi gained; the validation views say seed 0's Hi lost
  for seed, (lo, hi) in enumerate(((19.0, 18.5), (20.0, 20.5))):
    rec = _record(25.0, [[1, 25.0]])
    rec["seed"] = seed
    rec["stages"] = {"lo": {"step": 10, "psnr": 24.0}, "hi": {"step": 20, "psnr": 25.0}}
    rec["validation"] = {"split": "val", "num_views": 11,
                         "stages": {"lo": {"psnr": lo, "ssim": 0.8},
                                    "hi": {"psnr": hi, "ssim": 0.8}}}
    _write(root, "halo", seed, rec)
  _write(root, "nerf_tuned", 0, _record(20.0, [[1, 20.0]]))
  scenes = report.load(root)[("cpu", "budget")]
  table = report.validation_table(scenes)
  assert "| s1 | halo | 2 | 11 val | 19.50 ± 0.71 | 19.50 ± 1.41 | +0.00 |" in table
  assert "seed0: hi 18.50 < lo 19.00" in table and "seed1" not in table
  assert "nerf_tuned" not in table
  assert "seed0" not in report.stage_table(scenes)  # the test views' own table


def _front(points, final_s, final):
  return [{"at_s": t, "wall_s": t + 0.1, "stage": "hi", "step": 1, "psnr": p, "lpips": 0.3}
          for t, p in points] + [{"at_s": final_s, "wall_s": final_s, "stage": "hi", "step": 9,
                                  "final": True, "psnr": final, "lpips": 0.2}]


def test_front_table_gives_seconds_to_the_baselines_end(tmp_path):
  root, docs = str(tmp_path / "results"), str(tmp_path / "docs")
  os.makedirs(docs)
  for seed, end in enumerate((20.0, 22.0)):
    rec = _record(end, [[1, end]])
    rec["front"] = _front([(15, 10.0), (30, 15.0 + seed), (60, 18.0 + seed)], 240.0, end)
    rec["wall_s"] = 240.0
    _write(root, "nerf_tuned", seed, rec)
  for seed, mid in enumerate((20.5, 21.6)):  # mean 21.05 at 30 s: below 21; at 60 s: 22
    rec = _record(23.0, [[1, 23.0]])
    rec["front"] = _front([(15, 12.0), (30, mid), (60, 22.0)], 240.0, 23.0)
    _write(root, "halo", seed, rec)
  _write(root, "freenerf", 0, _record(15.0, [[1, 15.0]]))  # no front: no row
  by = report.load(root)[("cpu", "budget")]["s1"]
  table = fronts_report.front_table(by)
  assert "| method | seeds | 15 s | 30 s | 60 s | end | s to 21.00 dB (nerf_tuned's end) |" in table
  # nerf_tuned's mean front reaches its own mean end at the end; halo's at 30 s
  assert "| nerf_tuned | 2 | 10.00 ± 0.00 | 15.50 ± 0.71 | 18.50 ± 0.71 | 21.00 ± 1.41 | 240 | 1.00 |" in table
  assert "| halo | 2 | 12.00 ± 0.00 | 21.05 ± 0.78 | 22.00 ± 0.00 | 23.00 ± 0.00 | 30 | 0.12 |" in table
  assert "freenerf" not in table
  name = report.write_suite("cpu", "budget", report.load(root)[("cpu", "budget")], docs)
  assert os.path.exists(os.path.join(docs, f"{name}_s1_front.png"))
  # The README block: halo / nerf_tuned at each saved time and at the end,
  # halo's seconds to nerf_tuned's end and the ratio, the fronts figure, and
  # the count of scenes reached in half the time or less; a suite without
  # fronts keeps its final-PSNR rows.
  assert fronts_report.reach_ratio(by) == (30.0, 0.125)
  _write(root, "nerf_tuned", 0, _record(20.0, [[1, 20.0]]), scene="s2")  # no front
  _write(root, "nerf_tuned", 0, _record(19.0, [[1, 19.0]]), scene="s3")
  os.makedirs(os.path.join(root, "cpu", "steps"))
  os.rename(os.path.join(root, "cpu", "budget", "s3"), os.path.join(root, "cpu", "steps", "s3"))
  block = report.readme_block(report.load(root), docs)
  lines = block.splitlines()
  head = next(i for i, l in enumerate(lines) if l.startswith("| suite | scene | seeds |"))
  assert lines[head] == ("| suite | scene | seeds | 15 s | 30 s | 60 s | end | "
                         "halo: s to nerf_tuned's end (× its time) | code fingerprints |")
  # the records' commit is not in this repository: no fingerprint is known for it
  assert lines[head + 2].endswith("| s1 | 2 / 2 | 12.00 / 10.00 | 21.05 / 15.50 | "
                                  "22.00 / 18.50 | 23.00 / 21.00 | 30 (0.12) | unmeasured / unmeasured |")
  assert not any("| s2 |" in l for l in lines)  # no front: not a fronts row
  assert "on 1 of the 1 scenes where both have fronts" in block
  assert lines[-1].startswith("| [cpu/steps](docs/results/cpu_steps.md) | s3 |  | 19.00 |")
  assert os.path.exists(os.path.join(docs, "cpu_budget_fronts.png"))
  # the wall-clock mode's records stay on their own page, marked, and off the README
  os.rename(os.path.join(root, "cpu", "budget"), os.path.join(root, "cpu", "time"))
  suites_now = report.load(root)
  assert "cpu/time" not in report.readme_block(suites_now, docs)
  report.write_suite("cpu", "time", suites_now[("cpu", "time")], docs, plots=False)
  with open(os.path.join(docs, "cpu_time.md")) as f:
    assert "**Superseded.**" in f.read()


def test_frequency_calibration_on_validation_views_reads_no_test_view():
  from experiments.bench import calibrate_frequency, suites  # pylint: disable=g-import-not-at-top
  by = {s.name: s for s in calibrate_frequency.VALIDATION_SCENES}
  assert "knights" not in by and {"thin", "sparse", "dnerf_hellwarrior"} <= set(by)
  lego = calibrate_frequency.configure(by["lego_8view"], 300, "/tmp/unused", validation=True)
  assert (lego.data.test_split, lego.data.test_views) == ("train", suites.LEGO_VALIDATION_VIEWS)
  assert not set(suites.LEGO_VALIDATION_VIEWS.split(",")) & set(lego.data.train_views.split(","))
  hook = calibrate_frequency.configure(by["dnerf_hook"], 300, "/tmp/unused", validation=True)
  assert hook.data.test_split == "val"
  fern = calibrate_frequency.configure(by["fern_4view"], 300, "/tmp/unused", validation=True)
  assert fern.data.test_views == suites.FERN_VALIDATION_VIEWS


def test_a_front_ends_at_its_reference_seconds_not_its_wall_clock():
  rec = {"front": _front([(15.0, 10.0), (30.0, 12.0)], 240.07, 14.0)}
  rec["front"][-1]["wall_s"] = 119.7  # a fast machine trained the same steps in half the time
  assert [t for t, _, _ in fronts_report.front_of(rec)] == [15.0, 30.0, 240.07]


def _budget_record(psnr, config, curve=(), train=()):
  return {"psnr": psnr, "config": config, "curve": [list(p) for p in curve],
          "train_curve": [list(p) for p in train]}


def test_budget_study_reads_the_lead_and_where_the_baseline_stops_improving(tmp_path,
                                                                          monkeypatch):
  from experiments.bench import budget_report
  # a study of one scene here; the README's line waits for every scene of the study
  monkeypatch.setattr(budget_report.suites, "BUDGET_SCENES", ("lego_8view", "knights"))
  assert budget_report.readme_sentence({60.0: {}, 960.0: {}}) == ""
  assert budget_report.trend({60.0: 1.0, 240.0: 0.8, 960.0: 0.5}) == "falls"
  assert budget_report.trend({60.0: 0.1, 960.0: 0.3}) == "holds"
  assert budget_report.trend({60.0: -0.2, 960.0: 0.3}) == "rises"
  # nerf_tuned at 960 s: held-out peaks at 240 s (mean over seeds 22.0) and ends
  # 0.5 dB lower, while its training batches go from 25 to 27 dB
  curve = lambda top: [(120, 20.0), (240, top), (360, top - 0.5)]  # noqa: E731
  train = [(230, 24.0), (240, 25.0), (250, 26.0), (350, 27.0), (360, 27.0)]
  base = [_budget_record(20.0, "configs/blender.py:lego_8view_cpu", curve(21.5), train),
          _budget_record(20.2, "configs/blender.py:lego_8view_cpu", curve(22.5), train)]
  o = budget_report.overfitting(base)
  assert (o["peak_s"], o["peak"], o["end_s"]) == (240.0, 22.0, 360.0)
  assert o["heldout_change"] == -0.5 and o["train_change"] == 27.0 - 25.0
  halo = lambda p: [_budget_record(p, "configs/blender.py:lego_8view_cpu", curve(23.0))]  # noqa
  lego = "lego_8view"
  suites = {("budget_60", "budget"): {lego: {"nerf_tuned": base, "halo": halo(21.1)}},
            ("validation", "budget"): {lego: {"nerf_tuned": base, "halo": halo(20.6)},
                                       "spheres": {"halo": halo(30.0)}},
            ("budget_960", "budget"): {lego: {"nerf_tuned": base, "halo": halo(20.0)}}}
  assert budget_report.write(suites, str(tmp_path)) == ""    # knights has no runs
  monkeypatch.setattr(budget_report.suites, "BUDGET_SCENES", ("lego_8view",))
  line = budget_report.write(suites, str(tmp_path))
  page = (tmp_path / "budget_study.md").read_text()
  # lead 1.0 at 60 s, 0.5 at 240 s, -0.1 at 960 s: it falls, and HALO trails at 960 s
  assert "| blender | lego_8view | +1.00 | +0.50 | -0.10 | falls |" in page
  assert "spheres" not in page                      # not a scene of the study
  assert "nerf_tuned's held-out PSNR peaks at 240 s (22.00 dB" in page
  assert "moves -0.50 dB by 360 s, while its training PSNR moves +2.00 dB" in page
  assert (tmp_path / "budget_study_lego_8view.png").exists()
  assert "+1.00 dB at 60, +0.50 dB at 240, -0.10 dB at 960 reference seconds" in line
  assert ("HALO leads at 60 s and 240 s only on lego_8view (+1.00 to -0.10 dB)."
          " No run of either method collapsed. At 960 s on every validation scene (1 of 12 "
          "so far with both methods): ahead on 0 of 1; mean -0.10 dB") in line


def test_budget_study_says_what_its_probes_measured(tmp_path, monkeypatch):
  from experiments.bench import budget_report
  monkeypatch.setattr(budget_report.suites, "BUDGET_SCENES", ("lego_8view",))
  folder = tmp_path / "results" / "budget_960" / "probe" / "lego_8view"
  folder.mkdir(parents=True)
  psnr = {"own": 22.0, "own_twice_samples": 22.5, "baseline_sampler": 22.2,
          "twice_baseline_samples": 22.6, "nerf_tuned": 22.1, "nerf_tuned_twice_samples": 22.3}
  guide = {"window": 0.3, "num_samples": 32, "mean_window_share": 0.6,
           "hi_surface_in_window": 0.99, "error_share_where_window_misses": 0.02,
           "median_to_hi_surface": 0.07, "median_hi_to_baseline_surface": 0.004}
  for seed, shift in ((0, 0.0), (1, 0.2)):
    probe = {"psnr": {k: v + shift for k, v in psnr.items()}, "guide": guide,
             "empty_share": {"first": 0.002, "last": 0.01},
             "background_acc": {"halo": 0.005, "nerf_tuned": 0.008, "lo": 0.02,
                                "lo_sees_empty": 0.9}}
    (folder / f"seed{seed}.json").write_text(json.dumps(probe))
  lego = {"nerf_tuned": [_budget_record(20.0, "configs/blender.py:lego_8view_cpu")],
          "halo": [_budget_record(20.5, "configs/blender.py:lego_8view_cpu")]}
  suites = {(n, "budget"): {"lego_8view": lego} for n in ("budget_60", "validation",
                                                           "budget_960")}
  budget_report.write(suites, str(tmp_path), str(tmp_path / "results"))
  page = (tmp_path / "budget_study.md").read_text()
  assert "| 960 s | lego_8view (2) | 22.10 | 22.60 | 22.30 | 22.70 | 22.20 | 22.40 |" in page
  assert "Hi +0.50 dB with its own sampler, nerf_tuned +0.20 dB" in page
  assert "Hi's field is +0.30 dB from nerf_tuned's" in page
  assert ("Reading: at equal dense sampling Hi's field is ahead of nerf_tuned's (+0.30 dB); "
          "Hi's own sampler costs it 0.60 dB more (nerf_tuned's sampler at twice its samples "
          "recovers it).") in page
  assert "spans 60% of [near, far] (32 samples) and holds Hi's surface on 99.0%" in page
  assert "L_empty is 0.20% of Hi's loss over its first quarter and 1.00% over its last" in page
  assert ("halo 0.0050, nerf_tuned 0.0080, halo's Lo-NeRF 0.0200, which sees 90% of them "
          "empty") in page
  # HALO leads at every budget here: the page writes no shortfall section
  # (the section it writes below, once HALO trails at 960 s)
  assert "Where HALO falls short" not in page and "- **lego_8view at 960 s.** Reading" in page
  # at 960 s HALO trails: the section opens with the scene and its probes' reading
  behind = _budget_record(19.0, "configs/blender.py:lego_8view_cpu")
  behind["stages"] = {"lo": {"psnr": 19.5}}
  suites[("budget_960", "budget")] = {"lego_8view": {**lego, "halo": [behind]}}
  budget_report.write(suites, str(tmp_path), str(tmp_path / "results"))
  page = (tmp_path / "budget_study.md").read_text()
  assert ("- **lego_8view at 960 s**: halo − nerf_tuned -1.00 dB, Hi − Lo -0.50 dB. Reading: at "
          "equal dense sampling Hi's field is ahead of") in page
  assert "recovers it); Hi loses 0.50 dB on halo's own Lo-NeRF." in page
  assert "**lego_8view at 60 s**" not in page
  # no probes: no section
  budget_report.write(suites, str(tmp_path), str(tmp_path / "none"))
  assert "What sets the margin" not in (tmp_path / "budget_study.md").read_text()


def test_the_readme_groups_the_scenes_by_the_budgets_halo_leads_at():
  from experiments.bench import budget_report
  rec = lambda p: [{"psnr": p}]  # noqa: E731
  pair = lambda h, n: {"halo": rec(h), "nerf_tuned": rec(n)}  # noqa: E731
  by_budget = {60.0: {"a": pair(21, 20), "b": pair(19, 20), "c": pair(18, 20), "d": pair(22, 20)},
               960.0: {"a": pair(20.5, 20), "b": pair(21, 20), "c": pair(18, 20),
                       "d": pair(23, 20)}}
  assert budget_report.where_halo_leads(by_budget, ("a", "b", "c", "d")) == (
      "at every budget on a (+1.00 to +0.50 dB), d (+2.00 to +3.00 dB); "
      "at 960 s only on b (-1.00 to +1.00 dB); at no budget on c")


def test_the_largest_budget_is_reported_on_every_validation_scene_with_and_without_collapses():
  from experiments.bench import budget_report
  rec = lambda p, cfg, learned=None: dict(  # noqa: E731
      _budget_record(p, cfg), learned=learned or {"hi": "learned"}, stages={"lo": {}, "hi": {}})
  lego, thin = "configs/blender.py:lego_8view_cpu", "configs/procedural.py:thin_8view_cpu"
  hook = "configs/dnerf.py:hook_cpu"
  runs = {"lego_8view": {"halo": [rec(22.0, lego), rec(23.0, lego)],
                         "nerf_tuned": [rec(22.0, lego), rec(22.0, lego)]},
          "thin": {"halo": [rec(20.0, thin)],
                   "nerf_tuned": [rec(10.0, thin, {"hi": "collapsed"})]},
          "dnerf_hook": {"halo": [rec(18.0, hook)], "nerf_tuned": [rec(19.0, hook)]},
          "spheres": {"halo": [rec(25.0, thin)]}}   # one method only: not a pair yet
  lines = budget_report.every_scene_lines(runs, 960.0)
  text = "\n".join(lines)
  assert "(3 of 12 so far" in text
  assert "| blender | lego_8view | 22.50 (2) | 22.00 (2) | +0.50 | - | 2 | none |" in text
  assert "| procedural | thin | 20.00 (1) | 10.00 (1) | +10.00 | - | 2 | nerf_tuned |" in text
  assert "| dnerf | dnerf_hook | 18.00 (1) | 19.00 (1) | -1.00 | - | 3 | none |" in text
  # the mean of +0.50, +10.00, -1.00; without thin, of +0.50 and -1.00
  assert ("Ahead on 2 of 3; mean +3.17 dB (each scene weighs the same), -0.25 dB without the "
          "scenes where a run collapsed (thin). Per kind: blender +0.50 (1); dnerf -1.00 (1); "
          "procedural +10.00 (1).") in text
  # the goals: one scene behind is allowed; the mean without thin is -0.25;
  # dnerf (a Lo stage) is below +0.5, blender is not
  assert ("Goals (3 of 12 scenes so far): ahead on all but 1: met (behind: dnerf_hook -1.00); "
          "mean at least +1.0 dB where neither method collapsed: **not met** (-0.25); each kind "
          "with a Lo stage at least +0.5 dB: **not met** (dnerf -1.00).") in text
  assert budget_report.every_scene_lines({}, 960.0) == []
  # beside each kind's host spread: a margin no larger is inside it
  text = "\n".join(budget_report.every_scene_lines(runs, 960.0, {"dnerf": 1.2, "blender": 0.1}))
  assert "| dnerf | dnerf_hook | 18.00 (1) | 19.00 (1) | -1.00 | ±1.20 (inside) | 3 | none |" in text
  assert "| blender | lego_8view | 22.50 (2) | 22.00 (2) | +0.50 | ±0.10 | 2 | none |" in text
  assert "(behind: dnerf_hook -1.00, inside its kind's host spread ±1.20)" in text


def test_the_host_spread_is_each_kinds_largest_move_of_a_reruns_margin(tmp_path):
  from experiments.bench import code_version, host_spread
  lego, hook = "configs/blender.py:lego_8view_cpu", "configs/dnerf.py:hook_cpu"
  rec = lambda p, cfg, seed=0: dict(_budget_record(p, cfg), seed=seed)  # noqa: E731
  runs = {"lego_8view": {"halo": [rec(22.0, lego), rec(23.0, lego, 1)],
                         "nerf_tuned": [rec(21.0, lego), rec(22.0, lego, 1)]},
          "dnerf_hook": {"halo": [rec(18.0, hook)], "nerf_tuned": [rec(19.0, hook)]},
          "knights": {"halo": [rec(27.0, "configs/llff.py:knights_cpu")]}}
  again = {"lego_8view": {"halo": rec(22.3, lego), "nerf_tuned": rec(21.1, lego)},
           "dnerf_hook": {"halo": rec(17.0, hook), "nerf_tuned": rec(19.5, hook)},
           "knights": {"halo": rec(27.0, "configs/llff.py:knights_cpu")}}  # no pair
  for scene, by in again.items():
    for m, r in by.items():
      d = tmp_path / "budget_960" / "rerun" / scene / m
      d.mkdir(parents=True)
      (d / "seed0.json").write_text(json.dumps(r))
  found = host_spread.pairs(runs, host_spread.reruns(str(tmp_path), "budget_960"))
  assert sorted(found) == ["dnerf_hook", "lego_8view"]
  # margins +1.00 -> +1.20 on lego, -1.00 -> -2.50 on hook (seed 0's records only)
  assert found["lego_8view"]["moved"] == pytest.approx(0.2)
  assert found["dnerf_hook"]["moved"] == pytest.approx(-1.5)
  spread = host_spread.by_kind(found, code_version.kind_of)
  assert spread == pytest.approx({"blender": 0.2, "dnerf": 1.5})
  text = "\n".join(host_spread.lines(found, code_version.kind_of, 960.0))
  assert "| dnerf | dnerf_hook | 18.00 → 17.00 | 19.00 → 19.50 | -1.00 → -2.50 | -1.50 |" in text
  assert "Largest move of a margin: 1.50 dB; median 0.85 dB over 2 pairs." in text
  # a rerun of another config (a default changed since) is another run, not a pair
  switched = {"hi": {"steps": 6000, "sampler": {"switch_step": 2000}},
              "plan": {"hi": {"budget_steps": 2870}}}
  plain = {"hi": {"steps": 6000, "sampler": {"switch_step": 0}},
           "plan": {"hi": {"budget_steps": 2870}}}
  runs["lego_8view"]["halo"][0]["resolved_config"] = switched
  (tmp_path / "budget_960" / "rerun" / "lego_8view" / "halo" / "seed0.json").write_text(
      json.dumps(dict(again["lego_8view"]["halo"], resolved_config=plain)))
  assert sorted(host_spread.pairs(runs, host_spread.reruns(str(tmp_path), "budget_960"))) == [
      "dnerf_hook"]
  # a rescored record is the run of its config with the rescored fields laid over
  runs["lego_8view"]["halo"][0]["resolved_config"] = switched
  runs["lego_8view"]["halo"][0]["rescored_from"] = {"fields": [["hi.sampler.switch_step", 0]]}
  assert sorted(host_spread.pairs(runs, host_spread.reruns(str(tmp_path), "budget_960"))) == [
      "dnerf_hook", "lego_8view"]
  # a second rerun of a scene, on another host, is a pair of its own beside the first
  d = tmp_path / "budget_960" / "rerun" / "dnerf_hook"
  for m, p in (("halo", 18.4), ("nerf_tuned", 19.0)):
    (d / m / "seed0@xeon.json").write_text(json.dumps(dict(
        rec(p, hook), provenance={"cpu": {"model": "Intel Xeon"}, "time_utc": "2026-11-30T04"})))
  found = host_spread.pairs(runs, host_spread.reruns(str(tmp_path), "budget_960"))
  assert sorted(found) == ["dnerf_hook", "dnerf_hook @xeon", "lego_8view"]
  assert found["dnerf_hook @xeon"]["moved"] == pytest.approx(0.4)   # -1.0 -> -0.6
  assert host_spread.by_kind(found, code_version.kind_of) == pytest.approx(
      {"blender": 0.2, "dnerf": 1.5})
  text = "\n".join(host_spread.lines(found, code_version.kind_of, 960.0))
  assert ("| dnerf | dnerf_hook @xeon | 18.00 → 18.40 | 19.00 → 19.00 | -1.00 → -0.60 | +0.40 | "
          "halo ? → 2026-11-30, nerf_tuned ? → 2026-11-30 | Intel Xeon |") in text


def test_probe_retrains_of_the_same_code_join_the_host_spread():
  from experiments.bench import host_spread
  hook = "configs/dnerf.py:hook_cpu"
  rec = lambda p, commit: {"psnr": p, "config": hook, "seed": 0,  # noqa: E731
                           "provenance": {"git": {"commit": commit}}}
  runs = {"dnerf_hook": {"halo": [rec(18.0, "a")], "nerf_tuned": [rec(19.0, "a")]}}
  probe = {"scene": "dnerf_hook", "seed": 0, "record_psnr": {"halo": 18.5, "nerf_tuned": 18.0},
           "runs": {"halo": {"commit": "b"}, "nerf_tuned": {"commit": "b"}}}
  same = lambda record, git: True  # noqa: E731
  found = host_spread.probe_pairs(runs, [probe], same)
  assert list(found) == ["dnerf_hook (probe)"]
  assert found["dnerf_hook (probe)"]["moved"] == pytest.approx(1.5)   # -1.0 -> +0.5
  # another fingerprint's code, or the record's own runs probed, are no rerun
  assert host_spread.probe_pairs(runs, [probe], lambda record, git: False) == {}
  own = dict(probe, runs={"halo": {"commit": "a"}, "nerf_tuned": {"commit": "a"}})
  assert host_spread.probe_pairs(runs, [own], same) == {}
  # a probe of a run that sampled otherwise than the record's (a default changed) is no rerun
  switched = {"hi": {"sampler": {"kind": "depth_guided", "num_samples": 32, "switch_step": 2000,
                                 "switch_samples": 64, "switch_kind": ""}}}
  runs["dnerf_hook"]["halo"][0].update(resolved_config=switched, stages={"hi": {"step": 2870}})
  before = dict(probe, hi_sampler={"kind": "depth_guided", "num_samples": 32})
  assert host_spread.probe_pairs(runs, [before], same) == {}
  after = dict(probe, hi_sampler={"kind": "depth_guided", "num_samples": 64})
  assert list(host_spread.probe_pairs(runs, [after], same)) == ["dnerf_hook (probe)"]
