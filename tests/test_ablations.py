"""experiments/ablations.py: studies run at the suite's matched steps on
validation views, and their report, from hand-made result files."""
import json
import os
import subprocess
import sys

import pytest

from halo_jax import frozen, protocol  # pylint: disable=g-import-not-at-top
from halo_jax.configure import finish  # pylint: disable=g-import-not-at-top

REPO = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")
from experiments.bench import ablations, adopt, study_records  # pylint: disable=g-import-not-at-top


def _write(path, rec):
  os.makedirs(os.path.dirname(path), exist_ok=True)
  with open(path, "w") as f:
    json.dump(rec, f)


def _configured(study_name, scene_name, variant_name, seed, tmp_path):
  """(study, scene, config) of one run of a study, results and scratch in tmp_path."""
  study = ablations.STUDIES[study_name]
  scene = next(s for s in study.scenes if s.name == scene_name)
  variant = next(v for v in study.variants if v.name == variant_name)
  c = ablations.configure(study, scene, variant, seed, str(tmp_path / "scratch"),
                          str(tmp_path / "results"))
  return study, scene, c


def test_a_study_run_stops_each_stage_at_the_suites_mean_steps_on_validation_views(tmp_path):
  root = str(tmp_path / "results")
  study, scene, c = _configured("fog", "spheres", "density_bias_-4", 1, tmp_path)
  assert (c.data.test_split, c.data.test_views) == ("val", "all")
  assert c.budget_s == 0.0 and c.seed == 1
  assert (c.lo.stop_at_step, c.ray.stop_at_step, c.hi.stop_at_step) == (466, 732, 570)
  assert c.lo.steps > c.lo.stop_at_step  # schedules still span the stage's steps
  assert c.lo.model.density_bias == c.hi.model.density_bias == -4.0
  reference = next(v for v in study.variants if v.name == study.reference)
  c = ablations.configure(study, scene, reference, 0, str(tmp_path / "scratch"), root)
  assert c.lo.model.density_bias == -1.0  # the variant says its start, whatever the default
  # a suite run that trained less than a stage's floor is raised to it
  fern = [s for s in ablations.suites.CPU.scenes if s.name == "fern_4view"][0]
  c = ablations.configure(study, fern, reference, 0, str(tmp_path / "scratch"), root)
  assert c.ray.stop_at_step == c.ray.min_steps == 200


def test_report_gives_each_variant_against_the_reference_per_seed(tmp_path):
  root = str(tmp_path / "results")
  study = ablations.STUDIES["fog"]
  for variant, seed, psnr, lo in (("halo", 0, 15.0, 14.0), ("halo", 1, 11.0, 10.0),
                                  ("density_bias_-4", 0, 16.0, 15.0),
                                  ("density_bias_-4", 1, 20.0, 17.0)):
    _write(os.path.join(root, "ablations", "fog", "spheres", variant, f"seed{seed}.json"),
           {"scene": "spheres", "variant": variant, "seed": seed, "psnr": psnr, "wall_s": 100.0,
            "stages": {"lo": {"step": 1, "psnr": lo}, "hi": {"step": 2, "psnr": psnr}},
            "provenance": {"git": {"commit": "abc1234"}}})
  text = ablations.report("fog", study, root)
  assert "| `halo` | 2 | 13.00 ± 2.83 | 12.00 ± 2.83 | +1.00 |  | 100 |" in text
  assert "| `density_bias_-4` | 2 | 18.00 ± 2.83 | 16.00 ± 1.41 | +2.00 | +5.00 | 100 |" in text
  assert "| `density_bias_-4` | 2 | +5.00 | +1.00 | 0 |" in text
  assert "`relu` | 0 |" in text and "## lattice" not in text


def test_the_command_lists_its_plan_without_running(tmp_path):
  res = subprocess.run([sys.executable, "-m", "experiments.ablations", "--study=hi_samples",
                        "--dry_run", f"--results={tmp_path}", "--only=lattice/.*/seed0$"],
                       cwd=REPO, capture_output=True, text=True, timeout=120)
  assert res.returncode == 0, res.stderr[-2000:]
  assert res.stdout.split() == ["to", "run", "lattice/halo/seed0", "to", "run",
                                "lattice/hi_samples_16/seed0", "to", "run",
                                "lattice/hi_samples_8/seed0"]


def test_plan_refuses_an_empty_or_bad_selection():
  study = ablations.STUDIES["fog"]
  assert ablations._plan(study, "")  # pylint: disable=protected-access
  for only in ("no_such_scene", "halo+("):
    with pytest.raises(ValueError, match="--only="):
      ablations._plan(study, only)  # pylint: disable=protected-access


def test_a_time_study_keeps_the_suites_budget_and_reports_fronts_on_validation_views(tmp_path):
  root = str(tmp_path / "results")
  study, _, c = _configured("static_front", "spheres", "shares_20_05_75", 0, tmp_path)
  assert (c.data.test_split, c.data.test_views) == ("val", "all")
  assert c.budget_s == ablations.suites.CPU.budget_s and c.hi.stop_at_step == 0
  assert tuple(c.eval.front_s) == ablations.suites.CPU.front_s
  assert (c.budget_shares.lo, c.budget_shares.ray, c.budget_shares.hi) == (0.20, 0.05, 0.75)
  for variant, seed, front in (("nerf_tuned", 0, (12.0, 16.0, 18.0)),
                               ("halo", 0, (15.0, 17.0, 18.5)),
                               ("shares_20_05_75", 0, (15.5, 18.0, 19.0))):
    points = [{"at_s": t, "wall_s": t, "psnr": p} for t, p in zip((60.0, 120.0), front)]
    points.append({"at_s": 240.0, "wall_s": 240.0, "psnr": front[-1], "final": True})
    _write(os.path.join(root, "ablations", "static_front", "spheres", variant,
                        f"seed{seed}.json"),
           {"scene": "spheres", "variant": variant, "seed": seed, "psnr": front[-1],
            "wall_s": 240.0, "stages": {"hi": {"step": 9, "psnr": front[-1]}}, "front": points,
            "provenance": {"git": {"commit": "abc1234"}}})
  text = ablations.report("static_front", study, root)
  assert "240 s of training on one core" in text
  # nerf_tuned ends at 18.0: halo reaches it at its end, the new shares at 120 s
  assert "| halo | 1 | 15.00 | 17.00 | 18.50 | 240 | 1.00 |" in text
  assert "| shares_20_05_75 | 1 | 15.50 | 18.00 | 19.00 | 120 | 0.50 |" in text
  # over scenes and seeds: the variant against halo at each saved time
  assert "| `shares_20_05_75` | 1 | +0.50 | +1.00 | +0.50 |" in text


def test_a_variant_that_is_a_suite_run_adopts_its_record(tmp_path):
  # authors_static's `halo` on spheres is the validation suite's halo run:
  # the same resolved config (but for the scratch folder the scene is
  # generated in); halo_authors is not
  results = str(tmp_path / "results")
  suite = ablations.suites.VALIDATION
  scene = next(s for s in suite.scenes if s.name == "spheres")
  made = frozen.thaw(ablations.benchmark.configure(suite, scene, "halo", 0, "budget",
                                                   str(tmp_path / "other")))
  path = ablations.benchmark.result_path(results, "validation", "budget", scene, "halo", 0)
  git = {"commit": "abc1234", "code_tree": "tree_a", "code_dirty": False}
  record = {"psnr": 21.5, "method": "halo", "provenance": {"git": git},
            "resolved_config": json.loads(made.to_json_best_effort())}
  _write(path, record)
  table = {"tree_a": {"methods": {"halo": "fp_a"}}}
  study, study_scene, c = _configured("authors_static", "spheres", "halo", 0, tmp_path)
  same = lambda cfg, seed=0, fp="fp_a", method="halo": adopt.identical_suite_run(  # noqa: E731
      cfg, study_scene, method, seed, results, table=table, mine_fp=fp)
  found = same(c)
  assert found is not None and found[0] == path and found[1]["psnr"] == 21.5
  assert same(c, seed=1) is None
  _, _, theirs = _configured("authors_static", "spheres", "halo_authors", 0, tmp_path)
  assert same(theirs, method="halo_authors") is None
  # the same config from code that computes otherwise, or that no measured
  # fingerprint vouches for, is refused
  assert same(c, fp="fp_b") is None
  _write(path, dict(record, provenance={"git": dict(git, code_tree="tree_b")}))
  assert same(c) is None
  _write(path, dict(record, provenance={"git": dict(git, code_dirty=True)}))
  assert same(c, fp=adopt.code_version.MODIFIED) is None
  # one field apart is another run
  made.hi.lr_init *= 2
  _write(path, dict(record, resolved_config=json.loads(made.to_json_best_effort())))
  assert same(c) is None


def test_knights_baseline_at_halos_steps_trains_exactly_halos_count(tmp_path):
  """knights_steps: the baseline stopped where halo's costlier step stops it
  in the same reference time, its schedule as written (the plain baseline's)."""
  for budget in (60, 240):
    name = f"knights_steps_{budget}"
    halo, base, same = (protocol.effective(_configured(name, "knights", m, 0, tmp_path)[2])
                        for m in ("halo", "nerf_tuned", "nerf_tuned_halo_steps"))
    assert base.hi.budget_steps > halo.hi.budget_steps  # the baseline's step is cheaper
    assert same.hi.budget_steps == halo.hi.budget_steps == same.hi.stop_at_step
    assert same.hi.steps == base.hi.steps and same.hi.lr_init == base.hi.lr_init


def test_dynamic_crop_variants_change_only_his_crop(tmp_path):
  """dynamic_hi: `hi_crop_50` and `hi_no_crop` differ from halo's D-NeRF run
  in Hi's centre-crop steps alone, at every budget, so they take halo's step
  counts."""
  for budget in (60, 240, 960):
    name = f"dynamic_hi_{budget}"
    halo = _configured(name, "dnerf_lego", "halo", 0, tmp_path)[2]
    assert halo.hi.precrop_steps == 200
    for variant, crop in (("hi_crop_50", 50), ("hi_no_crop", 0)):
      c = frozen.thaw(_configured(name, "dnerf_lego", variant, 0, tmp_path)[2])
      assert c.hi.precrop_steps == crop
      c.hi.precrop_steps = halo.hi.precrop_steps
      assert c.to_dict() == halo.to_dict(), variant


def test_the_default_rule_checks_each_of_its_clauses():
  """docs/validation.md's rule: 2 seeds on every scene, no scene's mean
  worse than 0.3 dB, and a gain on the mean over scenes."""
  from experiments.bench import default_rule, suites
  from experiments.bench.study_types import Study, Variant
  scenes = tuple(suites.Scene(n, "configs/procedural.py:spheres_8view_cpu", 2)
                 for n in ("a", "b", "c"))
  study = Study("t", "q", scenes, (Variant("ref", "halo"), Variant("new", "halo")), "ref", 2)

  def recs(deltas, seeds=2):
    out = {}
    for scene, d in zip(("a", "b", "c"), deltas):
      out[(scene, "ref")] = [{"scene": scene, "seed": k, "psnr": 20.0} for k in range(seeds)]
      out[(scene, "new")] = [{"scene": scene, "seed": k, "psnr": 20.0 + d} for k in range(seeds)]
    return out

  rule = lambda deltas, seeds=2: default_rule.verdict(study, recs(deltas, seeds), "new")  # noqa
  assert rule((0.2, 0.1, -0.25)) == "passes"                    # a gain, no scene past 0.3
  assert rule((0.9, 0.5, -0.31)) == "fails: c -0.31"            # one scene loses too much
  assert rule((0.1, 0.1, -0.25)) == "fails: no gain on the mean (-0.02 dB)"
  assert rule((0.0, 0.0, 0.0)).startswith("fails: no gain on the mean")
  assert rule((0.5, 0.5, 0.5), seeds=1) == "not measured: a, b, c"   # fewer than 2 seeds


def test_a_suite_run_that_a_study_made_adopts_the_studys_record(tmp_path, monkeypatch):
  """The other way round: a study's variant that has become the default is
  the suite's run. Only a trained study run counts, of the same method and
  config, from code that computes the same; the suite's validation scores
  come from the record only where it holds them (one scored stage on every
  view of the validation split)."""
  results = str(tmp_path / "results")
  bench = ablations.benchmark
  suite = ablations.suites.VALIDATION
  scene = next(s for s in suite.scenes if s.name == "spheres")
  c = bench.configure(suite, scene, "nerf_tuned", 0, "budget", str(tmp_path / "scratch"))
  git = {"commit": "abc1234", "code_tree": "tree_a", "code_dirty": False}
  record = {"psnr": 23.9, "ssim": 0.9, "lpips": 0.1, "num_views": 24, "method": "nerf_tuned",
            "stages": {"hi": {"psnr": 23.9, "step": 2600}}, "heldout_learned": {"hi": "learned"},
            "provenance": {"git": git}, "wall_s": 900.0,
            # the fields ablations._write adds
            **study_records.study_fields("s", ablations.Variant("twin", "nerf_tuned", (), ""),
                                         c, ("hi",)),
            "resolved_config": json.loads(c.to_json_best_effort())}
  path = os.path.join(results, "ablations", "s", "spheres", "twin", "seed0.json")
  _write(path, record)
  table = {"tree_a": {"methods": {"nerf_tuned": "fp_a"}}}
  find = lambda cfg=c, seed=0, method="nerf_tuned", fp="fp_a": adopt.identical_study_run(  # noqa
      cfg, scene, method, seed, results, table=table, mine_fp=fp)
  assert find()[0] == path
  assert find(seed=1) is None and find(method="halo") is None and find(fp="fp_b") is None
  _write(path, dict(record, adopted_from={"path": "x"}))   # not a run of its own
  assert find() is None
  other = frozen.thaw(c)
  other.hi.lr_init *= 2
  assert find(cfg=other) is None
  # a rescored run is its reference's training with the render fields it names
  # (from its first step: dense renders a run stops short of change nothing)
  dense = frozen.thaw(c)
  dense.hi.sampler.update(dense_eval_after=1, dense_eval_samples=512)
  _write(path, dict(record, rescored_from={"path": "x", "fields": [
      ["hi.sampler.dense_eval_after", 1], ["hi.sampler.dense_eval_samples", 512]]}))
  assert find() is None and find(cfg=finish(dense))[0] == path
  late = frozen.thaw(c)
  late.hi.sampler.update(dense_eval_after=10 ** 6, dense_eval_samples=512)
  _write(path, record)
  assert find(cfg=finish(late))[0] == path
  # the suite's record: the study's names dropped, the validation scores derived
  _write(path, record)
  monkeypatch.setattr(adopt.code_version, "load", lambda: table)
  monkeypatch.setattr(adopt, "running_fingerprint", lambda *a, **k: "fp_a")
  made = bench._study_run(c, scene, "nerf_tuned", 0, "budget", results)
  assert made["adopted_from"]["path"] == "ablations/s/spheres/twin/seed0.json"
  assert not set(study_records.FIELDS) & set(made) and made["psnr"] == 23.9
  assert made["validation"] == {"split": "val", "num_views": 24, "stages": {
      "hi": {"psnr": 23.9, "ssim": 0.9, "learned": "learned"}}}
  assert bench._study_run(c, scene, "nerf_tuned", 0, "steps", results) is None
  # two scored stages: Lo's SSIM is not in the record, so the run is trained
  _write(path, dict(record, stages={"lo": {"psnr": 20.0}, "hi": {"psnr": 23.9}}))
  assert bench._study_run(c, scene, "nerf_tuned", 0, "budget", results) is None
  # the validation split is not the views the record was scored on
  data = dict(record["resolved_config"]["data"], test_views="r_0,r_1")
  assert adopt.validation_from(dict(record, resolved_config={"data": data}), "val") is None


def test_an_adopted_record_names_its_source_by_path_hash_and_commit(tmp_path):
  import hashlib  # pylint: disable=import-outside-toplevel
  from experiments.bench import adopt  # pylint: disable=import-outside-toplevel
  path = tmp_path / "validation" / "budget" / "spheres" / "halo" / "seed0.json"
  path.parent.mkdir(parents=True)
  path.write_text('{"psnr": 21.5}')
  got = adopt.source(str(path), str(tmp_path))
  assert got["path"] == "validation/budget/spheres/halo/seed0.json"
  assert got["sha256"] == hashlib.sha256(b'{"psnr": 21.5}').hexdigest()
  assert got["commit"] is None   # not in a git checkout
  committed = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))),
                           "results", "faults.json")
  assert len(adopt.source(committed, os.path.dirname(committed))["commit"] or "") == 40


def _one_budget_study(budget_s=60.0):
  from experiments.bench import suites
  from experiments.bench.study_types import Study, Variant
  scenes = tuple(suites.Scene(n, "configs/procedural.py:spheres_8view_cpu", 2) for n in ("a", "b"))
  return Study("t", "q", scenes, (Variant("ref", "halo"), Variant("new", "halo"),
                                  Variant("nerf_tuned", "nerf_tuned")), "ref", 2,
               budget="time", front=False, budget_s=budget_s)


def test_a_variant_identical_at_the_budget_is_not_judged_there():
  """The fingerprint's identity on every scene stands for runs; on some
  scenes only, the runs are judged as ever."""
  from experiments.bench import default_rule
  study = _one_budget_study()
  recs = {(s, v): [{"scene": s, "seed": k, "psnr": 20.0 + (v == "new") * 0.5} for k in range(2)]
          for s in ("a", "b") for v in ("ref", "new")}
  assert default_rule.verdict(study, {}, "new", {"a": True, "b": True}).startswith("identical")
  assert default_rule.verdict(study, recs, "new", {"a": True, "b": False}) == "passes"
  assert default_rule.verdict(study, {}, "new", {"a": True}) == "not measured: a, b"


def test_a_variant_is_judged_over_its_family_where_it_differs():
  from experiments.bench import default_rule
  same = "identical: the reference to the last digit"
  assert default_rule.judged_across({60.0: same, 240.0: same, 960.0: "passes"}) == \
      "passes at 960 s (identical at 60, 240 s)"
  assert default_rule.judged_across({60.0: "passes", 960.0: "passes"}) == "passes at 60, 960 s"
  assert default_rule.judged_across({60.0: same, 960.0: "fails: a -0.40"}) == \
      "fails at 960 s: a -0.40"
  assert default_rule.judged_across({60.0: same, 960.0: "not measured: a"}) == \
      "not measured at 960 s"
  assert default_rule.judged_across({60.0: "fails: b -0.50", 960.0: "passes"}) == \
      "fails at 60 s: b -0.50"
  assert default_rule.judged_across({60.0: same, 240.0: same}) == \
      "not measured: identical at every budget"


def test_identity_compares_each_variant_of_the_method_with_the_reference():
  from experiments.bench import identity
  study = _one_budget_study()
  # the plain baseline is no variant of the reference: nothing to check it against
  assert [(s.name, v.name) for s, v in identity.runs(study)] == \
      [("a", "ref"), ("a", "new"), ("b", "ref"), ("b", "new")]
  figs = {"a/ref": {"psnr": [20.0]}, "a/new": {"psnr": [20.0]},
          "b/ref": {"psnr": [20.0]}, "b/new": {"psnr": [20.1]}}
  assert identity.verdicts(study, figs) == {"new": {"a": True, "b": False}}
  del figs["b/new"]
  assert identity.verdicts(study, figs) == {"new": {"a": True}}
  # a twin of the baseline is checked against the baseline as it is
  import dataclasses  # pylint: disable=import-outside-toplevel
  from experiments.bench.study_types import Variant  # pylint: disable=import-outside-toplevel
  twin = Variant("nerf_tuned_late", "nerf_tuned", (("hi.sampler.dense_eval_after", 9),))
  study = dataclasses.replace(study, variants=study.variants + (twin,))
  assert [v.name for s, v in identity.runs(study, ["nerf_tuned_late"]) if s.name == "a"] == \
      ["nerf_tuned", "nerf_tuned_late"]
  figs = {"a/nerf_tuned": {"psnr": [15.0]}, "a/nerf_tuned_late": {"psnr": [15.0]}}
  assert identity.verdicts(study, figs) == {"nerf_tuned_late": {"a": True}}
  # a variant that names the one it adds to is checked against that one
  more = Variant("new_more", "halo", (("hi.sampler.dense_eval_after", 9),), against="new")
  study = dataclasses.replace(study, variants=study.variants + (more,))
  assert identity.reference_of(study, more).name == "new"
  assert [v.name for s, v in identity.runs(study, ["new_more"]) if s.name == "a"] == \
      ["new", "new_more"]


def test_every_budget_study_belongs_to_a_family_of_the_budget_study():
  from experiments.bench import budget_studies, suites
  for name in budget_studies.STUDIES:
    family = budget_studies.family_of(name)
    assert sorted(family) == sorted(suites.BUDGET_STUDY.values()), name
    assert all(budget_studies.STUDIES[n].budget_s == b for b, n in family.items())
  assert budget_studies.family_of("fog") == {}


def test_identity_checks_only_the_variants_asked_for():
  from experiments.bench import identity
  study = _one_budget_study()
  assert [v.name for _, v in identity.runs(study, ["new"])] == ["ref", "new", "ref", "new"]
  with pytest.raises(ValueError, match="nerf_tuned: not a variant the study can check"):
    identity.runs(study, ["nerf_tuned"])


def test_the_dense_eval_switch_lies_between_his_steps_at_240_and_960_s():
  """dense_eval's and the sampler switch's variants are identical at 60 and 240 s only if no scene's Hi
  reaches the switch there; it is judged at 960 s only if every one does."""
  from experiments.bench import budget_studies
  study = budget_studies.STUDIES["hi_window_960"]
  for scene in study.scenes:
    at_240 = budget_studies.hi_steps(scene, 240.0)
    at_960 = budget_studies.hi_steps(scene, 960.0)
    assert at_240 < budget_studies.DENSE_EVAL_AFTER <= at_960, (scene.name, at_240, at_960)
    assert at_240 < budget_studies.SAMPLES_SWITCH <= at_960, (scene.name, at_240, at_960)
  # and the baseline's twin (nerf_tuned trains more steps in the same time)
  for scene in study.scenes:
    steps = [budget_studies.hi_steps(scene, b, "nerf_tuned")
             for b in (240.0, 960.0)]
    assert steps[0] < budget_studies.DENSE_EVAL_AFTER <= steps[1], (scene.name, steps)


def test_a_baseline_variant_is_judged_against_its_own_method_and_per_kind():
  """The baseline's same chance is judged as the baseline's default: against
  the unchanged baseline, not against the study's reference; and where the
  study spans scene kinds, each kind alone as well."""
  from experiments.bench import default_rule, suites
  from experiments.bench.study_types import Study, Variant
  scenes = tuple(suites.Scene(n, "configs/procedural.py:spheres_8view_cpu", 2)
                 for n in ("a", "b", "c"))
  more = Variant("nerf_tuned_more", "nerf_tuned", (("hi.sampler.num_samples", 128),))
  study = Study("t", "q", scenes, (Variant("ref", "halo"), Variant("new", "halo"),
                                   Variant("nerf_tuned", "nerf_tuned"), more), "ref", 2)
  assert default_rule._judged(study) == [("new", "ref"), ("nerf_tuned_more", "nerf_tuned")]
  data = {"a": {"kind": "procedural"}, "b": {"kind": "procedural"}, "c": {"kind": "llff"}}
  psnr = {"ref": 30.0, "new": 30.0, "nerf_tuned": 20.0}
  gain = {"a": 0.5, "b": 0.5, "c": -0.4}   # the llff scene loses past the rule's 0.3 dB

  def rec(scene, variant, seed):
    p = psnr[variant] if variant in psnr else psnr["nerf_tuned"] + gain[scene]
    return {"scene": scene, "seed": seed, "psnr": p, "resolved_config": {"data": data[scene]}}
  recs = {(s, v): [rec(s, v, k) for k in range(2)] for s in data
          for v in ("ref", "new", "nerf_tuned", "nerf_tuned_more")}
  # against the study's reference (30 dB) it would lose 9.5 dB on every scene
  assert default_rule.verdict(study, recs, "nerf_tuned_more", reference="nerf_tuned") == \
      "fails: c -0.40"
  kinds = default_rule.by_kind(study, recs)
  assert {k: [s.name for s in v] for k, v in kinds.items()} == {"sphere": ["a", "b"],
                                                                "ndc": ["c"]}
  assert default_rule.verdict(study, recs, "nerf_tuned_more", reference="nerf_tuned",
                              scenes=kinds["sphere"]) == "passes"
  page = "\n".join(default_rule.lines("t", study, recs, ""))
  assert "| `nerf_tuned_more` | `nerf_tuned` | fails: c -0.40 | ndc: fails: c -0.40; " \
         "sphere: passes |" in page
