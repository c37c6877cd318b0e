"""The benchmark suite's plan, per-run configs and result files."""
import dataclasses
import json
import os
import shutil

import pytest

from halo_jax import configure, datasets, frozen, protocol  # pylint: disable=g-import-not-at-top
from halo_jax.stages import collapse  # pylint: disable=g-import-not-at-top
from experiments.bench import benchmark, suites  # pylint: disable=g-import-not-at-top
from conftest import resolved


def test_cpu_plan_is_seed_major_and_complete():
  todo = benchmark.plan(suites.CPU)
  expected = sum(s.seeds * len(s.methods) for s in suites.CPU.scenes)
  assert len(todo) == expected == len({(s.name, m, k) for s, m, k in todo})
  seeds = [k for _, _, k in todo]
  assert seeds == sorted(seeds)  # every scene at seed 0 before any at seed 1
  assert {s.name for s, _, k in todo if k == 0} == {s.name for s in suites.CPU.scenes}
  only = benchmark.plan(suites.CPU, only=r"^lego_8view/halo/")
  assert [(s.name, m, k) for s, m, k in only] == [("lego_8view", "halo", k) for k in range(3)]


def test_an_only_that_selects_nothing_or_is_no_regex_is_refused_in_one_line():
  with pytest.raises(ValueError, match="matches no run"):
    benchmark.plan(suites.CPU, only="^lego_8view/halo+unseen/")   # '+' unescaped
  with pytest.raises(ValueError, match="not a regular expression"):
    benchmark.plan(suites.CPU, only="lego_8view/(halo")
  assert benchmark.plan(suites.CPU, only=r"^lego_8view/halo\+unseen/seed0$")


@pytest.mark.parametrize("method", ["nerf_tuned", "halo"])
def test_modes_split_budget_and_steps_by_share(method, tmp_path):
  scene = suites.SMOKE.scenes[0]
  timed = benchmark.configure(suites.CPU, scene, method, 1, "budget", str(tmp_path))
  assert timed.seed == 1 and timed.budget_s == suites.CPU.budget_s
  assert timed.protocol == "budget"
  stepped = benchmark.configure(suites.CPU, scene, method, 1, "steps", str(tmp_path))
  assert stepped.budget_s == 0 and stepped.protocol == "steps"
  names = ["hi"] if method == "nerf_tuned" else ["lo", "ray", "hi"]
  total = sum(stepped.budget_shares[n] for n in names)
  for n in names:
    assert stepped[n].steps == round(suites.CPU.steps * stepped.budget_shares[n] / total)
  assert abs(sum(stepped[n].steps for n in names) - suites.CPU.steps) <= len(names)


def _value(c, dotted):
  for part in dotted.split("."):
    c = c[part]
  return c


def test_ingredient_variants_change_one_thing_to_the_other_baseline(tmp_path):
  """Each variant's changes are the other NeRF baseline's values of those
  fields, and the variant differs from its method nowhere else."""
  suite = suites.INGREDIENTS
  configs = {m: benchmark.configure(suite, suites.Scene("x", suite.scenes[0].config, 1), m, 0,
                                    "steps", str(tmp_path)) for m in ("nerf_paper", "nerf_tuned")}
  other = {"nerf_paper": "nerf_tuned", "nerf_tuned": "nerf_paper"}
  for scene in suite.scenes:
    (method,) = scene.methods
    c = frozen.thaw(benchmark.configure(suite, scene, method, 0, "steps", str(tmp_path)))
    for field, value in scene.overrides:
      assert _value(c, field) == value == _value(configs[other[method]], field), scene.name
      assert _value(configs[method], field) != value, scene.name
    base = configs[method].to_dict()
    for field, _ in scene.overrides:  # undo the changes: the method's config again
      configure.set_field(c, field, _value(configs[method], field))
    assert c.to_dict() == base, scene.name


@pytest.mark.slow
def test_smoke_suite_writes_and_skips(tmp_path):
  results, scratch = str(tmp_path / "results"), str(tmp_path / "scratch")
  scene = suites.SMOKE.scenes[0]
  r = benchmark.run_one("smoke", suites.SMOKE, scene, "nerf_tuned", 0, "budget", results, scratch)
  path = benchmark.result_path(results, "smoke", "budget", scene, "nerf_tuned", 0)
  with open(path) as f:
    saved = json.load(f)
  assert saved["psnr"] == pytest.approx(r["psnr"])
  assert set(saved["per_view"]) == {"r_0", "r_100"}
  assert saved["curve"] and all(t <= saved["wall_s"] + 1e-6 for t, _ in saved["curve"])
  for field in ("versions", "device", "cpu", "git", "matmul_peak_gflops", "command"):
    assert field in saved["provenance"]
  assert set(saved["provenance"]["git"]) == {"commit", "dirty", "code_tree", "code_dirty"}
  # the resolved config: the run's own fields, not the config file's name
  assert saved["resolved_config"]["hi"]["batch_rays"] == 128
  assert all(s["steps_per_s"] > 0 for s in saved["stages"].values())
  state = benchmark._state  # pylint: disable=protected-access
  assert state(path, scene, suites.SMOKE) == "done"
  assert state(path, scene, suites.SMOKE, add_fronts=True) == "done"
  now = benchmark.configure(suites.SMOKE, scene, "nerf_tuned", 0, "budget", scratch)
  assert state(path, scene, suites.SMOKE, config=now) == "done"
  # a default changed since the run, past where its fingerprint looks, at a
  # step the run reaches: rerun; at one it never reaches: the same run
  changed = frozen.replaced(now, {"hi.sampler.switch_step": 1})
  assert state(path, scene, suites.SMOKE, config=changed) == "stale config"
  unreached = frozen.replaced(now, {"hi.sampler.switch_step": 10 ** 6})
  assert state(path, scene, suites.SMOKE, config=unreached) == "done"
  assert os.path.getsize(path) < 20000
  # the front: the state at each of the suite's times the run reached, then the final
  front = saved["front"]
  assert [p["at_s"] for p in front[:-1]] == [t for t in suites.SMOKE.front_s
                                             if t <= saved["wall_s"]]
  assert front[-1]["final"] and front[-1]["psnr"] == pytest.approx(saved["psnr"])
  assert all(p["wall_s"] >= p["at_s"] and 0 < p["step"] for p in front)
  # the stage scored on every camera of the scene's validation split, after training
  val = saved["validation"]
  assert val["split"] == "val" and val["num_views"] == 24 and set(val["stages"]) == {"hi"}
  # above the best constant image (the val views' own mean colour, an oracle
  # no untrained field reaches): the run learned, and the score is of its renders
  c = frozen.thaw(benchmark.configure(suites.SMOKE, scene, "nerf_tuned", 0, "budget", scratch))
  c.data.update(test_split="val", test_views="all")
  val_images = datasets.load(c.data).test.images
  assert val["stages"]["hi"]["psnr"] > collapse.constant_psnr(val_images) + 1.0
  # a file without the scores gets them from the run's workdir: the same figures
  del saved["validation"]
  with open(path, "w") as f:
    json.dump(saved, f)
  args = ("smoke", scene, "nerf_tuned", 0, "budget", results, scratch)
  assert benchmark.add_validation(*args) == "scored"
  with open(path) as f:
    assert json.load(f)["validation"]["stages"]["hi"]["psnr"] == pytest.approx(
        val["stages"]["hi"]["psnr"], abs=1e-4)
  assert benchmark.add_validation(*args) == "has it"
  # a file from before fronts is rerun with --add_fronts, in a workdir that
  # has snapshots: the old workdir has none left to score, and says so
  saved.pop("front")
  with open(path, "w") as f:
    json.dump(saved, f)
  assert state(path, scene, suites.SMOKE) == "done"
  assert state(path, scene, suites.SMOKE, add_fronts=True) == "no front"
  shutil.rmtree(os.path.join(benchmark.workdir_of(scratch, "smoke", "budget", scene, "nerf_tuned",
                                                  0), "hi", "snapshots"))
  with pytest.raises(RuntimeError, match="has no snapshots"):
    benchmark.run_one("smoke", suites.SMOKE, scene, "nerf_tuned", 0, "budget", results, scratch)


def test_the_budget_studys_suites_are_the_validation_suite_at_other_budgets(tmp_path):
  # the 60- and 960-s points differ from the validation suite's 240-s runs in
  # the budget alone: same terms, same scene configs, one scene of each kind
  from experiments.bench import benchmark, suites
  from halo_jax.configure import set_field
  assert suites.BUDGET_STUDY == {"budget_60": 60.0, "validation": 240.0, "budget_960": 960.0}
  kinds = set()
  for name, budget_s in suites.BUDGET_STUDY.items():
    suite = suites.SUITES[name]
    assert suite.budget_s == budget_s and suite.cores == suites.VALIDATION.cores
    assert suite.overrides == suites.VALIDATION.overrides and suite.front_s == ()
  for scene in suites.BUDGET_60.scenes:
    same = next(s for s in suites.VALIDATION.scenes if s.name == scene.name)
    assert scene == same
    kinds.add(scene.config.split(":")[0])
    for method in scene.methods:
      a = benchmark.configure(suites.BUDGET_960, scene, method, 0, "budget", str(tmp_path))
      b = frozen.thaw(benchmark.configure(suites.VALIDATION, same, method, 0, "budget",
                                          str(tmp_path)))
      set_field(b, "budget_s", 960.0)
      for n in ("lo", "ray", "hi"):   # the curve's spacing follows the budget
        if n in a.stages:
          set_field(b, f"{n}.eval_every_s", a[n].eval_every_s)
      assert json.loads(a.to_json_best_effort()) == json.loads(
          resolved(b).to_json_best_effort())
  assert kinds == {"configs/blender.py", "configs/dnerf.py", "configs/llff.py",
                   "configs/stanford_lf.py"}
  # 960 s covers every validation scene, with more seeds on the dynamic ones
  assert [s.name for s in suites.BUDGET_960.scenes] == [s.name for s in suites.VALIDATION.scenes]
  for scene, same in zip(suites.BUDGET_960.scenes, suites.VALIDATION.scenes):
    dynamic = scene.config.startswith("configs/dnerf.py")
    assert scene.seeds == (suites.DYNAMIC_SEEDS_960 if dynamic else same.seeds)
    assert dataclasses.replace(scene, seeds=same.seeds) == same


def test_a_record_short_of_a_switch_added_since_is_the_same_run(tmp_path):
  # the 60-s run of a 360-degree scene: Hi stops far short of HALO's switch
  scene = next(s for s in suites.VALIDATION.scenes if s.name == "spheres")
  now = benchmark.configure(suites.BUDGET_60, scene, "halo", 0, "budget", str(tmp_path))
  assert now.hi.sampler.switch_step > protocol.effective(now).hi.budget_steps
  record = {"resolved_config": json.loads(
      frozen.replaced(now, {"hi.sampler.switch_step": 0}).to_json_best_effort())}
  same = benchmark._same_config  # pylint: disable=protected-access
  assert same(now, record)
  # the same record past the switch: another run, trained again
  past = frozen.replaced(now, {"hi.sampler.switch_step": 0,
                               "plan.hi.budget_steps": now.hi.sampler.switch_step + 1})
  assert not same(frozen.replaced(now, {"plan.hi.budget_steps": now.hi.sampler.switch_step + 1}),
                  {"resolved_config": json.loads(past.to_json_best_effort())})
  # a switch of another size, unreached, is no switch either
  assert same(frozen.replaced(now, {"hi.sampler.switch_samples": 128}), record)


def test_no_switch_is_no_switch_whatever_its_other_fields_say(tmp_path):
  """A study's variant that turns a default switch off (switch_step 0) is the
  run recorded before the switch was a default, though the method now sets
  switch_samples too; a run past a switch of another size is not."""
  scene = next(s for s in suites.BUDGET_960.scenes if s.name == "spheres")
  now = benchmark.configure(suites.BUDGET_960, scene, "nerf_tuned", 0, "budget", str(tmp_path))
  assert (now.hi.sampler.switch_step, now.hi.sampler.switch_samples) == (2000, 128)
  assert protocol.effective(now).hi.budget_steps > 2000
  off = frozen.replaced(now, {"hi.sampler.switch_step": 0})
  before = frozen.replaced(off, {"hi.sampler.switch_samples": 64})
  same = benchmark._same_config  # pylint: disable=protected-access
  assert same(off, {"resolved_config": json.loads(before.to_json_best_effort())})
  assert not same(now, {"resolved_config": json.loads(frozen.replaced(
      now, {"hi.sampler.switch_samples": 64}).to_json_best_effort())})
