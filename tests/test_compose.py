"""One composition: every entry point makes the same run of a scene, a method
and overrides (configure.compose), frozen, with derived fields that follow
their sources, and a launch refused for its input leaves nothing behind."""
import json
import os

import pytest
from absl import flags
from ml_collections import config_flags

from halo_jax import cli, configure, frozen, methods, pipeline
from halo_jax.datasets.base import DataError
from halo_jax.methods import halo, nerf_tuned
from halo_jax.registry import ConfigError
from experiments.bench import suites

# Every scene config the suites run, and the paper-size configs of each file.
SCENES = sorted({s.config for suite in suites.SUITES.values() for s in suite.scenes}
                | {"configs/default.py", "configs/blender.py:lego_8view",
                   "configs/blender.py:lego_oneside", "configs/llff.py:fern_4view",
                   "configs/dnerf.py:lego", "configs/stanford_lf.py:knights",
                   "configs/capture.py:8view_cpu", "configs/capture.py:4view_ff_cpu"})
OVERRIDES = {
    "none": {},
    "samples": {"hi.sampler.num_samples": 64},
    "budget": {"protocol": "budget", "budget_s": 120.0},
    "paper": {"protocol": "paper", "budget_s": 0.0},
    "steps": {"hi.steps": 100},
}


def _command_line(spec, method, overrides):
  """What halo-train composes from --config=spec --config.<field>=<value> ...
  (absl's parse, ml_collections' typing of each value, cli.config_of_flags)."""
  fv = flags.FlagValues()
  argv = ["halo-train", f"--config={spec}"] + [f"--config.{k}={v}" for k, v in overrides.items()]
  config_flags.DEFINE_config_file("config", None, "scene", flag_values=fv, sys_argv=argv)
  fv(argv)
  return cli.config_of_flags(fv["config"], method)


def _outcome(make):
  try:
    return json.loads(make().to_json_best_effort())
  except (ConfigError, ValueError) as e:
    return f"refused: {e}"


@pytest.mark.parametrize("spec", SCENES)
def test_every_entry_point_composes_the_same_run(spec):
  for method in methods.METHODS.names():
    for name, over in OVERRIDES.items():
      composed = _outcome(lambda: configure.compose(spec, method, over))  # noqa: B023
      launched = _outcome(lambda: _command_line(spec, method, over))  # noqa: B023
      scene = configure.load_scene(spec)
      from_scene = _outcome(lambda: configure.compose(scene, method, over))  # noqa: B023
      assert composed == launched == from_scene, (spec, method, name)


def test_the_composed_config_is_frozen_and_the_pipeline_refuses_another():
  c = configure.compose("configs/blender.py:lego_8view_cpu", "halo")
  assert isinstance(c, frozen.Frozen)
  with pytest.raises(AttributeError, match="immutable"):
    c.hi.steps = 3
  with pytest.raises(ConfigError, match="composed, frozen config"):
    pipeline.run(frozen.thaw(c), "/nonexistent/never_written")
  edited = frozen.thaw(c)
  edited.plan.hi.budget_steps = 7   # the protocol's count, edited after compose
  with pytest.raises(ConfigError, match="not resolved"):
    pipeline.run(frozen.freeze(edited), "/nonexistent/never_written")


def test_derived_fields_follow_their_sources_whoever_sets_them():
  fern = "configs/llff.py:fern_4view_cpu"
  for samples in (16, 32, 64):
    c = configure.compose(fern, "halo", {"hi.sampler.num_samples": samples})
    assert c.hi.sampler.num_full == int(samples * halo.FULL_FRACTION)
  # an override of the derived field itself wins
  assert configure.compose(fern, "halo", {"hi.sampler.num_samples": 64,
                                          "hi.sampler.num_full": 3}).hi.sampler.num_full == 3
  # nerf_tuned keeps each micro-batch's samples as the scene's Hi has them
  scene = configure.load_scene("configs/blender.py:lego_8view_cpu")
  per_part = scene.hi.batch_rays * scene.hi.sampler.num_samples // scene.hi.microbatches
  for samples in (64, 128):
    c = configure.compose(scene, "nerf_tuned", {"baseline.num_samples": samples})
    assert c.hi.sampler.num_samples == samples
    assert c.hi.batch_rays * samples // c.hi.microbatches == per_part
    assert c.hi.microbatches == nerf_tuned.parts_for(scene, samples, scene.hi.batch_rays)
  # the authors' one-side steps are a fact of the paper-size scene, not of
  # the protocol or the order it was given in
  cpu = configure.compose("configs/blender.py:lego_oneside_cpu", "halo_authors",
                          OVERRIDES["paper"])
  assert (cpu.lo.steps, cpu.ray.steps, cpu.hi.steps) == (1500, 3000, 6000)
  paper = configure.compose("configs/blender.py:lego_oneside", "halo_authors")
  assert (paper.lo.steps, paper.ray.steps, paper.hi.steps) == (4200, 42000, 28000)
  # a share of Hi's steps follows an override of them
  short = configure.compose("configs/blender.py:lego_oneside", "halo_authors", {"hi.steps": 2800})
  assert short.hi.precrop_steps == round(1000 * 2800 / 28000)


def test_the_protocol_argument_is_the_protocol_fields():
  spec = "configs/blender.py:lego_8view"
  as_arg = configure.compose(spec, "halo", protocol=60.0)
  as_fields = configure.compose(spec, "halo", {"protocol": "budget", "budget_s": 60.0})
  assert as_arg.to_dict() == as_fields.to_dict() and as_arg.plan.hi.init_from_lo
  with pytest.raises(ValueError, match="protocol='fast'"):
    configure.compose(spec, "halo", protocol="fast")


def test_an_unknown_field_is_one_line_with_the_nearest_names():
  with pytest.raises(KeyError, match="'hi.sampler.num_sampels'; nearest: hi.sampler.num_samples"):
    configure.compose("configs/default.py", "halo", {"hi.sampler.num_sampels": 64})
  line = cli.config_refusal(["halo-train", "--config=configs/default.py",
                             "--config.hi.sampler.num_sampels=64"])
  assert line.startswith("--config.hi.sampler.num_sampels: ") and "\n" not in line
  assert "nearest: hi.sampler.num_samples" in line
  assert cli.config_refusal(["halo-train", "--config=configs/default.py",
                             "--config.hi.sampler.num_samples=64"]) == ""


def test_a_config_that_does_not_load_is_one_line_naming_it():
  variant = cli.config_refusal(["halo-train", "--config=configs/blender.py:lego_9view"])
  assert variant.startswith("--config=configs/blender.py:lego_9view: unknown variant 'lego_9view'")
  assert "\n" not in variant
  missing = cli.config_refusal(["halo-train", "--config=configs/nosuch.py:x"])
  assert missing == "--config=configs/nosuch.py:x: config file 'configs/nosuch.py' not found"
  assert cli.config_refusal(["halo-train", "--config=configs/blender.py:lego_8view_cpu"]) == ""


def test_a_launch_refused_for_its_data_leaves_the_workdir_untouched(tmp_path):
  wd = tmp_path / "run"
  bad = configure.compose("configs/blender.py:lego_8view_cpu", "nerf_tuned",
                          {"data.root": str(tmp_path / "missing")})
  with pytest.raises(DataError, match="does not exist: set HALO_DATA"):
    pipeline.run(bad, str(wd))
  assert not os.path.exists(wd)
