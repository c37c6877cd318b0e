"""Micro-batches: a step's batch run in parts is the same step as the whole."""
import json
import os

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from conftest import tiny_config
from halo_jax import pipeline, raycast, rng, stages
from halo_jax.stages import microbatch
from halo_jax.stages import step as train_step
from test_lightfield import lf_config, write_light_field
from halo_jax.configure import finish  # pylint: disable=g-import-not-at-top


def test_per_ray_draws_do_not_depend_on_the_cut():
  keys = jax.random.split(jax.random.PRNGKey(3), 8)
  for draw in (rng.uniform, rng.normal):
    whole = draw(keys, (8, 5))
    np.testing.assert_array_equal(draw(keys[2:6], (4, 5)), whole[2:6])
    assert len(np.unique(np.asarray(whole))) == 40  # rows differ from each other
  a, b = rng.split(keys, 2)
  np.testing.assert_array_equal(rng.uniform(a[4:], (4, 3)), rng.uniform(a, (8, 3))[4:])
  assert not np.array_equal(rng.uniform(a, (8, 3)), rng.uniform(b, (8, 3)))
  # One key keeps jax.random's draw.
  k = jax.random.PRNGKey(0)
  np.testing.assert_array_equal(rng.uniform(k, (2, 3)), jax.random.uniform(k, (2, 3)))
  with pytest.raises(ValueError, match="first axis must be the rays"):
    rng.uniform(keys, (4, 5))


def test_part_of_and_checks():
  x = jnp.arange(12)
  np.testing.assert_array_equal(microbatch.part_of(x, (1, 3)), [4, 5, 6, 7])
  assert microbatch.part_of(x, None) is x
  c = tiny_config()
  c.lo.microbatches = 5
  with pytest.raises(ValueError, match="microbatches=5 does not divide lo.batch_rays=64"):
    microbatch.check_parts(c.lo, 64, "lo.batch_rays")


def test_gradients_of_parts_equal_the_whole_batch():
  # A loss whose per-ray terms use per-ray random draws, as the stages' do.
  def loss_fn(w, data, key, step, part=None):
    keys = microbatch.part_of(jax.random.split(key, data.shape[0]), part)
    x = microbatch.part_of(data, part)
    noise = rng.normal(keys, x.shape)
    loss = jnp.mean(jnp.tanh(x @ w + noise) ** 2)
    return loss, {"m": loss}
  w = jax.random.normal(jax.random.PRNGKey(1), (4, 4))
  data = jax.random.normal(jax.random.PRNGKey(2), (32, 4))
  key = jax.random.PRNGKey(5)
  (l1, a1), g1 = train_step.loss_and_grads(loss_fn, w, data, key, 0, parts=1)
  (l4, a4), g4 = train_step.loss_and_grads(loss_fn, w, data, key, 0, parts=4)
  np.testing.assert_allclose(l4, l1, rtol=1e-6)
  np.testing.assert_allclose(a4["m"], a1["m"], rtol=1e-6)
  np.testing.assert_allclose(g4, g1, rtol=1e-5, atol=1e-7)


def _train_losses(c, wd):
  pipeline.run(finish(c), wd)
  recs = [json.loads(l) for l in open(os.path.join(wd, "metrics.jsonl"))]
  return [(r["stage"], r["step"], r["loss"]) for r in recs
          if "loss" in r and not r.get("heldout")]


@pytest.mark.slow
def test_microbatched_light_field_follows_the_whole_batch(tmp_path):
  root = write_light_field(str(tmp_path / "lf"))
  out = {}
  for parts in (1, 4):
    c = lf_config(root)
    c.eval.save_images = False
    c.hi.update(log_every=1, microbatches=parts)
    c.hi.joint.random_rays = 16   # drawn for the whole step, split like the batch
    out[parts] = _train_losses(c, str(tmp_path / f"mb{parts}"))
  assert len(out[1]) == 6
  np.testing.assert_allclose([r[2] for r in out[4]], [r[2] for r in out[1]], rtol=1e-4)


def test_blocks_render_what_one_pass_renders():

  per_ray = lambda o, d, t: {"a": jnp.sum(jnp.sin(o * d), -1), "b": o * 2}
  o = jax.random.normal(jax.random.PRNGKey(0), (10, 3))
  d = jax.random.normal(jax.random.PRNGKey(1), (10, 3))
  whole = per_ray(o, d, None)
  for block in (0, 3, 5, 16):  # 3: the last block is padded
    out = raycast.in_blocks(per_ray, block, o, d, None)
    assert out["a"].shape == (10,) and out["b"].shape == (10, 3)
    np.testing.assert_allclose(out["a"], whole["a"], rtol=1e-6)
    np.testing.assert_array_equal(out["b"], whole["b"])
