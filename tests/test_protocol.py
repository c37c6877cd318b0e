"""The protocol as a value (halo_jax/protocol.py) and the step table behind
its budgets (halo_jax/step_table.py): step counts in closed form, keys by
size, and runs that train exactly the counts they were given."""
import json
import math
import os

import pytest

from conftest import resolved, tiny_config
from halo_jax import (config_files, configure, frozen, pipeline, protocol, registry, runs,
                      step_table)
from halo_jax.stages import budget, order
from conftest import editable  # pylint: disable=g-import-not-at-top
from halo_jax.configure import finish  # pylint: disable=g-import-not-at-top

STEP_S = {"lo": 0.1, "ray": 0.01, "hi": 0.2}
SETUP_S = {"lo": 0.0, "ray": 2.0, "hi": 0.5}


def _table(tmp_path, config, names=("lo", "ray", "hi"), setup_s=None):
  """A step table holding config's keys at STEP_S and SETUP_S (or setup_s).
  Keys are of a resolved config (its protocol decides Hi's copy of Lo, which
  widens Hi's input)."""
  path = str(tmp_path / "table.json")
  setup_s = SETUP_S if setup_s is None else setup_s
  config = resolved(config.copy_and_resolve_references())
  entries = {step_table.key(config, n): {"step_s": STEP_S[n], "setup_s": setup_s[n]}
             for n in names}
  with open(path, "w") as f:
    json.dump({"machine": {"cpu": "test"}, "entries": entries}, f)
  return path


def _budgeted(tmp_path, seconds=100.0, steps=10 ** 5):
  c = tiny_config()
  c.budget_shares.update(lo=0.3, ray=0.07, hi=0.63)
  for n in ("lo", "ray", "hi"):
    c[n].steps = steps
  protocol.budget(c, seconds)
  c.step_table = _table(tmp_path, c)
  return resolved(c)


def _trained(c):
  """c as its stages train it: its plan laid over the stages."""
  return protocol.effective(c)


def test_a_budget_is_its_shares_in_steps_of_the_table(tmp_path):
  c = _trained(_budgeted(tmp_path))
  # lo: 30 s / 0.1; ray: (37 - 30 - 2) / 0.01; hi: (100 - 37 - 0.5) / 0.2, each
  # step that crosses its share taken
  assert (c.lo.budget_steps, c.ray.budget_steps, c.hi.budget_steps) == (
      300, math.ceil(5.0 / 0.01 - 1e-9), math.ceil(62.5 / 0.2 - 1e-9))
  assert c.hi.ref_offset_s == pytest.approx(37.0)
  assert budget.last_step(c.hi) == c.hi.budget_steps
  assert all(c[n].max_seconds == 0 for n in ("lo", "ray", "hi"))  # no clock in the loop


def test_a_stage_capped_before_its_share_leaves_its_time_to_the_next(tmp_path):
  c = tiny_config()
  c.budget_shares.update(lo=0.3, ray=0.07, hi=0.63)
  c.lo.steps, c.ray.steps, c.hi.steps = 100, 10 ** 5, 10 ** 5
  protocol.budget(c, 100.0)
  c.step_table = _table(tmp_path, c)
  c = _trained(resolved(c))
  assert c.lo.budget_steps == 100                        # 10 s of its 30
  assert c.ray.budget_steps == math.ceil((37 - 10 - 2) / 0.01 - 1e-9)
  assert c.hi.ref_offset_s == pytest.approx(37.0)        # the ray field took what lo left


def test_a_share_too_small_still_trains_the_floor_and_the_next_stage_pays(tmp_path):
  c = tiny_config()
  c.budget_shares.update(lo=0.3, ray=0.0001, hi=0.6999)
  for n in ("lo", "ray", "hi"):
    c[n].steps = 10 ** 5
  c.ray.min_steps = 200
  protocol.budget(c, 100.0)
  c.step_table = _table(tmp_path, c)
  c = _trained(resolved(c))
  assert c.ray.budget_steps == 200
  spent = 30.0 + 2.0 + 200 * 0.01
  assert c.hi.ref_offset_s == pytest.approx(spent)
  assert c.hi.budget_steps == math.ceil((100.0 - spent - 0.5) / 0.2 - 1e-9)


def test_the_last_stage_has_no_floor_so_a_method_ends_within_its_budget(tmp_path):
  c = tiny_config()
  c.budget_shares.update(lo=0.3, ray=0.07, hi=0.63)
  for n in ("lo", "ray", "hi"):
    c[n].update(steps=10 ** 5, min_steps=100)
  protocol.budget(c, 10.0)
  c.step_table = _table(tmp_path, c)
  c = _trained(resolved(c))
  assert c.lo.budget_steps == 100 and c.ray.budget_steps == 100      # floors: 10 s, 1 s
  # hi: nothing left after lo's 10 s, ray's 2 s set-up and 1 s: one step, not 100
  assert c.hi.budget_steps == 1


def test_resolving_again_gives_the_same_counts_and_follows_a_new_budget(tmp_path):
  c = _budgeted(tmp_path)
  first = c.to_dict()
  assert resolved(c).to_dict() == first
  c.budget_s = 50.0
  assert _trained(resolved(c)).lo.budget_steps == 150


def test_a_size_the_table_lacks_is_left_to_the_run_to_measure(tmp_path):
  c = tiny_config()
  protocol.budget(c, 100.0)
  c.step_table = _table(tmp_path, c, names=("lo",))
  resolved(c)
  assert protocol.summary(c)["measured"]
  c = _trained(c)
  assert c.lo.budget_steps > 0 and c.lo.max_seconds == 0
  # the ray field is missing: it and the stages after it measure themselves
  assert c.ray.budget_steps == 0 and c.ray.max_seconds > 0 and c.hi.max_seconds > 0


@pytest.mark.parametrize("field,value,match", [
    ("protocol", "wallclock", r"protocol='wallclock': must be one of"),
    ("budget_s", 10.0, r"budget_s=10.0 with protocol='paper'"),
])
def test_a_protocol_that_does_not_fit_its_budget_is_refused(field, value, match):
  c = tiny_config()
  protocol.paper(c)
  c[field] = value
  with pytest.raises(registry.ConfigError, match=match):
    resolved(c)


def test_the_budget_protocol_needs_seconds():
  c = tiny_config()
  c.protocol = "budget"
  with pytest.raises(registry.ConfigError, match=r"budget_s=0.0 with protocol='budget'"):
    resolved(c)


def test_keys_follow_sizes_not_scene_names():
  key = lambda spec, n, method="halo", **o: step_table.key(configure.load(spec, method, o), n)
  # another Blender scene of the same protocol and size shares lego's entries
  for n in ("lo", "ray", "hi"):
    assert key("configs/blender.py:chair_8view_cpu", n) == key("configs/blender.py:lego_8view_cpu", n)
  # one-side lego has 14 views: only the ray field's set-up differs
  assert key("configs/blender.py:lego_oneside_cpu", "hi") == key(
      "configs/blender.py:lego_8view_cpu", "hi")
  assert key("configs/blender.py:lego_oneside_cpu", "ray") != key(
      "configs/blender.py:lego_8view_cpu", "ray")
  lego = "configs/blender.py:lego_8view_cpu"
  assert key(lego, "hi", **{"hi.lr_init": 1e-3}) == key(lego, "hi")         # a rate: no
  assert key(lego, "hi", **{"hi.batch_rays": 2048}) != key(lego, "hi")      # a size: yes
  assert key(lego, "hi", **{"hi.sampler.num_samples": 64}) != key(lego, "hi")
  assert key(lego, "hi", "nerf_tuned") != key(lego, "hi")                   # the method: yes
  # every scene kind's kind is in its key
  assert key("configs/dnerf.py:lego_cpu", "lo").split("|")[1] == "dnerf"


def test_the_shipped_table_covers_the_cpu_suite_and_gives_its_steps():
  """Every key of the CPU suite's halo and nerf_tuned runs is in the table,
  and a 240-s budget gives the steps the suite's reference runs reached
  (lego 8 views: nerf_tuned 830 and 838 steps, halo's Hi 740 and 752)."""
  from experiments.bench import benchmark, suites
  for scene in suites.CPU.scenes:
    for method in set(scene.methods) & {"halo", "nerf_tuned"}:
      c = benchmark.configure(suites.CPU, scene, method, 0, "budget", "/tmp/unused")
      summary = protocol.summary(c)
      assert not summary["measured"], (scene.name, method, summary)
  lego = suites.CPU.scenes[0]
  tuned = benchmark.configure(suites.CPU, lego, "nerf_tuned", 0, "budget", "/tmp/unused")
  halo = benchmark.configure(suites.CPU, lego, "halo", 0, "budget", "/tmp/unused")
  assert 820 <= _trained(tuned).hi.budget_steps <= 845
  assert 735 <= _trained(halo).hi.budget_steps <= 760
  assert step_table.machine()["cpu"]


def test_budgeted_runs_train_exactly_their_counts(scene_root, tmp_path):
  """A run from the table trains the counts resolve gave, and its front and
  curve fall on the reference clock's steps, whatever the machine."""
  c = tiny_config()
  c.data.root = scene_root
  c.eval.lpips = False
  c.budget_shares.update(lo=0.5, ray=0.1, hi=0.4)
  for n in ("lo", "ray", "hi"):
    c[n].update(steps=1000, eval_every=0)
  protocol.budget(c, 2.0)
  c.step_table = _table(tmp_path, c, setup_s={"lo": 0.0, "ray": 0.0, "hi": 0.0})
  c.eval.front_s = (0.25, 1.105, 1.5)
  c.lo.eval_every_s, c.hi.eval_every_s = 0.5, 0.4
  t = _trained(resolved(c))
  # lo: 1.0 s / 0.1; ray: 0.2 s / 0.01; hi: 0.8 s / 0.2
  assert (t.lo.budget_steps, t.ray.budget_steps, t.hi.budget_steps) == (10, 20, 4)
  infos = pipeline.run(finish(c), str(tmp_path / "run"))
  assert {n: i["step"] for n, i in infos.items()} == {"lo": 10, "ray": 20, "hi": 4}
  assert infos["hi"]["reference_end_s"] == pytest.approx(2.0)

  def points(stage):
    with open(os.path.join(tmp_path, "run", stage, "snapshots", "index.json")) as f:
      return [(p["at_s"], p["step"]) for p in json.load(f)["points"]]
  # each time at the first step whose reference clock reaches it
  assert points("lo") == [(0.25, 3)]       # 0.3 s
  assert points("ray") == [(1.105, 11)]    # 1.0 + 11 x 0.01 s
  assert points("hi") == [(1.5, 2)]        # 1.2 + 2 x 0.2 s
  # the held-out curve's seconds are the reference clock's too
  offset, step_s = {"lo": 0.0, "hi": 1.2}, {"lo": 0.1, "hi": 0.2}
  with open(os.path.join(tmp_path, "run", "metrics.jsonl")) as f:
    held = [json.loads(line) for line in f if '"heldout": true' in line]
  assert held and all(r["reference_s"] == pytest.approx(offset[r["stage"]]
                                                        + r["step"] * step_s[r["stage"]])
                      for r in held)
  assert [t for t, _ in runs.read_curve(str(tmp_path / "run"))] == pytest.approx(
      sorted(r["reference_s"] for r in held))


def test_a_self_measured_stage_fixes_its_count_once_and_keeps_it(scene_root, tmp_path):
  c = tiny_config(method="")
  c.data.root = scene_root
  c.eval.lpips = False
  c.hi.update(steps=10 ** 4, eval_every=0, checkpoint_every=10 ** 4, log_every=100)
  protocol.budget(c, 3.0)
  c.step_table = str(tmp_path / "empty.json")
  resolved(c)
  assert _trained(c).hi.max_seconds == pytest.approx(3.0)  # the budget's share, in the plan
  assert c.hi.max_seconds == 0.0                          # the user's field stays as asked
  wd = str(tmp_path / "run")
  infos = pipeline.run(finish(c), wd)
  fixed = budget.read_fixed(wd, "hi")
  assert infos["hi"]["step"] == fixed["steps"] == infos["hi"]["fixed_steps"]
  # its 3 s less the set-up it did before its loop, in its own steps
  assert 0.9 * 3.0 / fixed["step_s"] <= fixed["steps"] <= budget.fixed_count(_trained(c).hi,
                                                                           fixed["step_s"])
  # a relaunch keeps the count it fixed: nothing is left to train
  again = pipeline.run(finish(c), wd)
  assert again["hi"]["step"] == fixed["steps"]


def _stages(c) -> dict:
  """The stages as they train (the plan laid over them)."""
  t = _trained(c)
  return {n: t[n].to_dict() for n in ("lo", "ray", "hi")}


@pytest.mark.parametrize("scene", ["configs/llff.py:fern_4view", "configs/blender.py:lego_8view"])
def test_a_budget_on_the_command_line_resolves_as_one_in_the_file(scene, tmp_path):
  """A paper-size HALO config launched with the budget as --config overrides
  gets the stages it gets with the budget written in its file: Hi starts as
  Lo's copy either way (the method states it; the protocol applies it)."""
  from absl import flags
  from ml_collections import config_flags
  from halo_jax import cli, config_files
  path, _, variant = config_files.resolve(scene).partition(":")
  in_file = tmp_path / "budgeted.py"
  in_file.write_text(
      "import importlib.util\n"
      f"_spec = importlib.util.spec_from_file_location('scene', {path!r})\n"
      "_module = importlib.util.module_from_spec(_spec)\n"
      "_spec.loader.exec_module(_module)\n\n\n"
      "def get_config():\n"
      f"  c = _module.get_config({variant!r})\n"
      "  c.protocol, c.budget_s = 'budget', 180.0\n"
      "  return c\n")
  launched = {}
  for name, argv in (("line", [f"--config={scene}", "--config.protocol=budget",
                               "--config.budget_s=180"]),
                     ("file", [f"--config={in_file}"])):
    fv, argv = flags.FlagValues(), ["halo-train"] + argv
    config_flags.DEFINE_config_file("config", None, "scene", flag_values=fv, sys_argv=argv)
    fv(argv)
    launched[name] = cli.config_of_flags(fv["config"], "halo")
  assert _trained(launched["line"]).hi.init_from_lo
  assert _trained(launched["line"]).hi.encoding.with_lo
  assert _stages(launched["line"]) == _stages(launched["file"])
  # and the method applied to an already budgeted scene gives the same again
  assert _stages(editable(configure.load_scene(str(in_file)), "halo")) == \
      _stages(launched["line"])


def test_a_budget_given_after_the_method_still_copies_lo_and_paper_does_not():
  c = configure.load("configs/llff.py:fern_4view", "halo",
                     {"protocol": "budget", "budget_s": 180.0})
  assert _trained(c).hi.init_from_lo and _trained(c).hi.encoding.with_lo
  assert c.plan.hi.encoding.with_lo and not c.hi.encoding.with_lo  # the protocol's, apart
  again = configure.finish(c)
  assert _stages(again) == _stages(c)  # idempotent
  cpu_as_paper = configure.load("configs/llff.py:fern_4view_cpu", "halo",
                                {"protocol": "paper", "budget_s": 0.0})
  assert not (_trained(cpu_as_paper).hi.init_from_lo
              or _trained(cpu_as_paper).hi.encoding.with_lo)
  # an explicit choice stands: the copy is the method's field, not forced
  fresh = configure.load("configs/llff.py:fern_4view_cpu", "halo",
                         {"hi.copy_lo_under_budget": False})
  assert not (_trained(fresh).hi.init_from_lo or _trained(fresh).hi.encoding.with_lo)


def test_resolve_writes_the_plan_and_leaves_the_asked_fields_as_they_are():
  """What the protocol works out is a section of its own: the stage fields a
  user sets are the same before and after resolve, under every protocol,
  and the stages train with the plan laid over them."""
  for spec, method in (("configs/llff.py:fern_4view_cpu", "halo"),
                       ("configs/blender.py:lego_oneside_cpu", "halo_authors"),
                       ("configs/dnerf.py:hook_cpu", "nerf_tuned")):
    for over in ({}, {"protocol": "paper", "budget_s": 0.0},
                 {"protocol": "steps", "budget_s": 0.0, "hi.stop_at_step": 7}):
      c = configure.load(spec, method, over)
      asked = frozen.thaw(c)
      del asked["plan"]
      again = frozen.thaw(c)
      protocol.resolve(again, order.graph(again))
      del again["plan"]
      assert again.to_dict() == asked.to_dict(), (spec, method, over)
      t = _trained(c)
      assert "plan" not in t
      for name, fields in c.plan.items():
        for dotted, value in config_files.dotted_fields(fields.to_dict()).items():
          node = t[name]
          for part in dotted.split("."):
            node = node[part]
          assert node == value, (spec, method, name, dotted)
  # the authors' recipe spans its schedules over the steps a budget gives:
  # in the plan; its `steps` as the method states them
  a = configure.load("configs/blender.py:lego_oneside_cpu", "halo_authors")
  assert a.hi.steps == 6000 and a.plan.hi.steps == _trained(a).hi.budget_steps < 6000


def test_a_workdir_started_before_the_plan_was_a_section_relaunches(tmp_path):
  """A workdir whose config.json holds the protocol's fields in its stages
  (the layout before `plan`) matches the same run composed now, and not
  another one."""
  from halo_jax.stages import workdir as workdirs
  c = configure.load("configs/llff.py:fern_4view_cpu", "halo")
  old = protocol.applied(json.loads(c.to_json_best_effort()))
  assert "plan" not in old and old["hi"]["encoding"]["with_lo"] and old["hi"]["budget_steps"] > 0
  (tmp_path / "config.json").write_text(json.dumps(old))
  workdirs.check_workdir(c, str(tmp_path))
  other = configure.load("configs/llff.py:fern_4view_cpu", "halo", {"hi.batch_rays": 256})
  with pytest.raises(workdirs.WorkdirMismatch, match="hi.batch_rays"):
    workdirs.check_workdir(other, str(tmp_path))
  # and a config without a plan is its own effective value
  assert protocol.effective(protocol.effective(c)).to_dict() == protocol.effective(c).to_dict()
