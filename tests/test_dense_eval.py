"""Hi's held-out renders turn dense (sampler.dense_eval_after) once the stage
has trained that long: identical before, on the whole ray after."""
import json
import os

import numpy as np
import pytest

from halo_jax import pipeline
from halo_jax.configure import finish
from conftest import pipeline_config


def _heldout(workdir, stage="hi"):
  with open(os.path.join(workdir, "metrics.jsonl")) as f:
    rows = [json.loads(line) for line in f]
  return {r["step"]: r["psnr"] for r in rows if r.get("stage") == stage and r.get("heldout")}


@pytest.mark.slow
def test_renders_turn_dense_after_the_step_and_not_before(scene_root, tmp_path):
  runs = {}
  for after in (0, 4):
    c = pipeline_config(scene_root, steps=4)
    c.eval.lpips = False
    c.hi.update(eval_every=2)
    c.hi.sampler.update(dense_eval_after=after, dense_eval_samples=24)
    wd = str(tmp_path / f"after{after}")
    runs[after] = (pipeline.run(finish(c), wd)["hi"], _heldout(wd))
  (plain, plain_curve), (dense, dense_curve) = runs[0], runs[4]
  assert plain_curve[2] == dense_curve[2]  # before the switch: the same render, bit for bit
  assert plain["eval"]["psnr"] != dense["eval"]["psnr"]  # at the end: 24 samples on the ray
  assert np.isfinite(dense["eval"]["psnr"])


def test_a_bad_switch_is_one_line_naming_the_field():
  from halo_jax import validate  # pylint: disable=import-outside-toplevel
  from conftest import tiny_config  # pylint: disable=import-outside-toplevel
  c = tiny_config()
  c.hi.sampler.dense_eval_after = -1
  with pytest.raises(validate.ConfigError,
                     match=r"hi\.sampler\.dense_eval_after=-1: must be an integer >= 0"):
    validate.validate(finish(c))
  c = tiny_config()
  c.hi.sampler.update(dense_eval_after=10, dense_eval_samples=0)
  with pytest.raises(validate.ConfigError, match=r"hi\.sampler\.dense_eval_samples=0"):
    validate.validate(finish(c))
