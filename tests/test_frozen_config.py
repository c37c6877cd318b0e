"""A run is composed once and frozen: the stages receive an immutable config,
and what a run records at its start is the config its stages trained with."""
import json
import os

import ml_collections
import pytest

from halo_jax import frozen, pipeline, protocol
from halo_jax.stages import base, order
from conftest import pipeline_config
from halo_jax.configure import finish  # pylint: disable=g-import-not-at-top


def test_the_stages_receive_an_immutable_config(tmp_path, monkeypatch):
  c = pipeline_config(str(tmp_path / "scene"), steps=4)
  seen = []
  trainer_of = base.trainer_of

  def spying(config, name):
    trainer = trainer_of(config, name)

    class Spy:
      def __getattr__(self, attr):  # what the pipeline asks of a trainer beside train
        return getattr(trainer, attr)

      def train(self, ctx):
        seen.append((name, ctx.config))
        with pytest.raises(AttributeError, match="immutable"):
          ctx.config[name].steps = 1
        with pytest.raises(AttributeError, match="immutable"):
          ctx.config.stages = "hi"
        return trainer.train(ctx)
    return Spy()
  monkeypatch.setattr(base, "trainer_of", spying)
  workdir = str(tmp_path / "run")
  pipeline.run(finish(c), workdir)
  assert [n for n, _ in seen] == ["lo", "ray", "hi"]
  assert all(isinstance(x, ml_collections.FrozenConfigDict) for _, x in seen)
  with open(os.path.join(workdir, "config.json")) as f:
    at_start = json.load(f)
  for _, config in seen:  # the value the run recorded first, as the stages train it
    assert json.loads(config.to_json_best_effort()) == protocol.applied(at_start)
  assert "plan" in at_start and "plan" not in json.loads(seen[0][1].to_json_best_effort())
  assert at_start == json.loads(protocol.resolve(frozen.thaw(c), order.graph(c)).to_json_best_effort())


def test_replaced_makes_a_new_value_and_leaves_the_old_one():
  c = frozen.freeze(pipeline_config("/tmp/unused", steps=4))
  d = frozen.replaced(c, {"lo.max_seconds": 3.0, "hi.steps": 9})
  assert (d.lo.max_seconds, d.hi.steps) == (3.0, 9)
  assert (c.lo.max_seconds, c.hi.steps) == (0.0, 4)
  with pytest.raises(KeyError, match="lo.no_such_field"):
    frozen.replaced(c, {"lo.no_such_field": 1})


def test_editing_a_thawed_section_leaves_the_frozen_config_and_its_later_thaws():
  """ml_collections' ConfigDict(frozen section) shares nested sections with
  the frozen value's cached copy; thaw must not pass that on."""
  f = frozen.freeze(ml_collections.ConfigDict({"hi": {"sampler": {"num_samples": 8}}}))
  section = frozen.thaw(f.hi)
  section.sampler.num_samples = 16
  assert frozen.replaced(f.hi, {"sampler.num_samples": 32}).sampler.num_samples == 32
  assert frozen.thaw(f).hi.sampler.num_samples == 8
  assert f.hi.sampler.num_samples == 8
