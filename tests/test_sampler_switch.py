"""A stage's sampler switch (halo_jax/sampler_switch.py): more samples a ray
after a step. Before it a run computes what it did without one (same plan,
same key, same numbers); past it the budget prices its steps by their own
table entry, the loop takes the switched step, and held-out views are scored
as the field trains."""
import json
import math
import os

import ml_collections
import numpy as np
import pytest

from conftest import pipeline_config, resolved, tiny_config
from halo_jax import frozen, pipeline, protocol, registry, sampler_switch, step_table, validate
from halo_jax.configure import finish
from halo_jax.stages import budget

STEP_S = {"lo": 0.1, "ray": 0.01, "hi": 0.2}
AFTER_S = 0.5   # Hi's step past its switch
SETUP_S = {"lo": 0.0, "ray": 2.0, "hi": 0.5}


def _switching(switch_step, seconds=100.0, after=True, tmp_path=None):
  """tiny_config under a budget, Hi switching to 16 samples at
  `switch_step`, with a table of STEP_S (and AFTER_S past the switch where
  `after`)."""
  c = tiny_config()
  c.budget_shares.update(lo=0.3, ray=0.07, hi=0.63)
  for n in ("lo", "ray", "hi"):
    c[n].steps = 10 ** 5
  c.hi.sampler.switch_samples = 16
  protocol.budget(c, seconds)
  keyed = resolved(c.copy_and_resolve_references())  # the switch step is not in a key
  c.hi.sampler.switch_step = switch_step
  entries = {step_table.key(keyed, n): {"step_s": STEP_S[n], "setup_s": SETUP_S[n]}
             for n in ("lo", "ray", "hi")}
  if after:
    entries[step_table.after_switch_key(keyed, "hi")] = {"step_s": AFTER_S, "setup_s": 0.0}
  c.step_table = str(tmp_path / f"table{switch_step}_{after}.json")
  with open(c.step_table, "w") as f:
    json.dump({"machine": {"cpu": "test"}, "entries": entries}, f)
  return c


def test_the_sampler_after_the_switch():
  c = tiny_config()
  c.hi.sampler.update(switch_step=5, switch_samples=16)
  assert sampler_switch.sampler_fields(c.hi.sampler) == {
      "kind": c.hi.sampler.kind, "num_samples": 16, "switch_step": 0}
  # to the fine pass: the window's own samples become its first pass
  c.hi.sampler.update(kind="depth_guided", num_samples=8, switch_kind="depth_guided_fine")
  assert sampler_switch.sampler_fields(c.hi.sampler) == {
      "kind": "depth_guided_fine", "num_samples": 16, "num_coarse": 8, "switch_step": 0}
  assert [sampler_switch.after(c.hi, s) for s in (4, 5, 6)] == [False, False, True]


def test_the_switch_fields_leave_the_key_and_the_steps_after_it_have_their_own():
  plain = finish(tiny_config())
  c = tiny_config()
  c.hi.sampler.update(switch_step=5, switch_samples=16)
  c = finish(c)
  assert step_table.key(c, "hi") == step_table.key(plain, "hi")
  after = step_table.after_switch_key(c, "hi")
  assert after != step_table.key(c, "hi")
  more = tiny_config()
  more.hi.sampler.num_samples = 16
  assert after == step_table.key(finish(more), "hi")  # Hi sampling so from its first step


def test_a_run_short_of_its_switch_has_the_plan_it_had_without_one(tmp_path):
  # Hi's share: (100 - 37 - 0.5) / 0.2 = 313 steps, short of 400
  short = resolved(_switching(400, tmp_path=tmp_path))
  plain = _switching(0, tmp_path=tmp_path)
  plain.step_table = short.step_table
  resolved(plain)
  assert short.plan.to_dict() == plain.plan.to_dict()
  assert protocol.effective(short).hi.budget_steps == math.ceil(62.5 / 0.2 - 1e-9)


def test_past_the_switch_the_steps_are_priced_at_their_own_rate(tmp_path):
  c = protocol.effective(resolved(_switching(100, tmp_path=tmp_path)))
  # 100 steps at 0.2 s, then the 62.5 - 20 s left at 0.5 s a step
  assert c.hi.budget_steps == 100 + math.ceil(42.5 / AFTER_S - 1e-9)
  assert (c.hi.ref_switch_step, c.hi.ref_after_step_s) == (100, AFTER_S)
  # the reference clock: continuous at the switch, at the new rate past it
  at = lambda step: budget.reference_seconds(c.hi, step, c.hi.ref_offset_s)
  assert at(100) == pytest.approx(37.0 + 0.5 + 20.0)
  assert at(101) - at(100) == pytest.approx(AFTER_S)
  assert at(99) == pytest.approx(at(100) - 0.2)
  assert at(c.hi.budget_steps) == pytest.approx(100.0, abs=AFTER_S)
  stages = protocol.summary(c)["stages"]
  assert stages["hi"]["after_switch"]["from_step"] == 100
  assert "after_switch" not in stages["lo"]


def test_a_budget_past_a_switch_the_table_cannot_price_is_refused(tmp_path):
  with pytest.raises(registry.ConfigError,
                     match=r"hi\.sampler\.switch_step=100: the stage passes its switch"):
    resolved(_switching(100, after=False, tmp_path=tmp_path))
  resolved(_switching(400, after=False, tmp_path=tmp_path))  # short of it: no entry needed


@pytest.mark.parametrize("fields,match", [
    (dict(switch_step=-3), r"hi\.sampler\.switch_step=-3: must be an integer >= 0"),
    (dict(switch_step=5, switch_samples=0), r"hi\.sampler\.switch_samples=0"),
    (dict(switch_step=5, switch_kind="stratified"),
     r"hi\.sampler\.switch_kind='stratified': switches from 'depth_guided'"),
])
def test_a_bad_switch_is_one_line_naming_the_field(fields, match):
  c = tiny_config()
  c.hi.sampler.kind = "depth_guided"
  c.hi.sampler.update(**fields)
  with pytest.raises(validate.ConfigError, match=match):
    validate.validate(finish(c))


def _losses(workdir):
  with open(os.path.join(workdir, "metrics.jsonl")) as f:
    rows = [json.loads(line) for line in f]
  return {r["step"]: r["loss"] for r in rows
          if r.get("stage") == "hi" and "loss" in r and not r.get("heldout")}


@pytest.mark.slow
def test_the_steps_after_the_switch_sample_more_and_a_resumed_run_agrees(scene_root, tmp_path):
  """Hi's losses agree with a run without the switch up to it and differ
  after; a run killed past the switch resumes on the switched step."""
  runs = {}
  for switch in (0, 3):
    c = pipeline_config(scene_root, steps=6)
    c.eval.lpips = False
    c.hi.sampler.update(switch_step=switch, switch_samples=16)
    wd = str(tmp_path / f"switch{switch}")
    runs[switch] = (pipeline.run(finish(c), wd)["hi"], _losses(wd))
  (plain, plain_loss), (switched, switched_loss) = runs[0], runs[3]
  assert [plain_loss[s] for s in (1, 2, 3)] == [switched_loss[s] for s in (1, 2, 3)]
  assert all(plain_loss[s] != switched_loss[s] for s in (4, 5, 6))
  assert plain["eval"]["psnr"] != switched["eval"]["psnr"]
  assert switched["compile_s"] > 0
  # the same run stopped after 4 steps, then resumed to 6
  c = pipeline_config(scene_root, steps=6)
  c.eval.lpips = False
  c.hi.sampler.update(switch_step=3, switch_samples=16)
  wd = str(tmp_path / "resumed")
  c.hi.stop_at_step = 4
  pipeline.run(finish(c), wd)
  c.hi.stop_at_step = 0
  resumed = pipeline.run(finish(c), wd)["hi"]
  np.testing.assert_allclose(_losses(wd)[6], switched_loss[6], rtol=1e-5)
  assert resumed["eval"]["psnr"] == pytest.approx(switched["eval"]["psnr"], abs=1e-3)


def test_a_self_measured_count_prices_the_steps_past_the_switch_at_their_own_rate():
  cfg = frozen.freeze(ml_collections.ConfigDict(
      dict(max_seconds=10.0, steps=10 ** 4, stop_at_step=0, budget_steps=0, min_steps=1)))
  assert budget.fixed_count(cfg, 0.1) == 100
  # 50 steps at 0.1 s, then (10 - 5) / 0.3 = 16.7: the 17th crosses the time
  assert budget.fixed_count(cfg, 0.1, 0.3, 50) == 67
  assert budget.fixed_count(cfg, 0.1, 0.3, 200) == 100  # never reaches its switch
  assert budget.measured_seconds(0.1, 0.3, 50, 40, 60) == pytest.approx(10 * 0.1 + 10 * 0.3)
  assert budget.measured_seconds(0.1, 0.0, 50, 40, 60) == pytest.approx(20 * 0.1)


@pytest.mark.slow
def test_a_self_measured_stage_times_its_steps_past_its_switch_and_keeps_its_count(
    scene_root, tmp_path):
  c = tiny_config(method="")
  c.data.root = scene_root
  c.eval.lpips = False
  c.hi.update(steps=10 ** 4, eval_every=0, checkpoint_every=10 ** 4, log_every=100)
  c.hi.sampler.update(switch_step=30, switch_samples=32)
  protocol.budget(c, 3.0)
  c.step_table = str(tmp_path / "empty.json")  # no entry: the stage times itself
  wd = str(tmp_path / "run")
  infos = pipeline.run(finish(c), wd)
  fixed = budget.read_fixed(wd, "hi")
  assert "after_pending" not in fixed and fixed["after_step_s"] > 0
  assert infos["hi"]["step"] == fixed["steps"] == infos["hi"]["fixed_steps"] > 30
  assert infos["hi"]["measured_after_step_s"] == fixed["after_step_s"]
  hi = protocol.effective(finish(c)).hi
  # its 3 s (less any set-up before its loop), each side of the switch at its rate
  assert fixed["steps"] <= max(30 + budget.MEASURE_STEPS, budget.fixed_count(
      hi, fixed["step_s"], fixed["after_step_s"], 30))
  assert 30 * fixed["step_s"] + (fixed["steps"] - 31) * fixed["after_step_s"] < 3.0
  again = pipeline.run(finish(c), wd)  # a relaunch keeps the count it fixed
  assert again["hi"]["step"] == fixed["steps"]
