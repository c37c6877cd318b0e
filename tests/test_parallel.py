"""Data parallelism on 2 CPU devices and micro-batches: the same loss
trajectory as one device running the whole batch at once."""
import json
import os
import subprocess
import sys

import numpy as np
import pytest

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

CODE = """
import json, sys
sys.path.insert(0, {tests!r})
import jax, jax.numpy as jnp
from conftest import pipeline_config, tiny_config
from halo_jax import parallel, pipeline, stages
from halo_jax.configure import finish  # pylint: disable=g-import-not-at-top

assert jax.device_count() == 2, jax.devices()
c = tiny_config()
c.parallel.data_parallel = True
mesh = parallel.make_mesh(c.parallel)
x = jax.jit(lambda v: parallel.shard_batch(v * 2.0, mesh))(jnp.arange(8.0))
shards = sorted(tuple(s.data.tolist()) for s in x.addressable_shards)
out = {{"shards": shards, "losses": {{}}}}
for dp, parts in ((False, 1), (False, 4), (True, 2)):
  c = pipeline_config({root!r}, 8, parts, dp)
  c.eval.lpips = False
  assert c.hi.empty.weight > 0 and c.hi.density_noise > 0
  wd = {wd!r} + "/dp" + str(int(dp)) + "_" + str(parts)
  pipeline.run(finish(c), wd)
  recs = [json.loads(l) for l in open(wd + "/metrics.jsonl")]
  out["losses"][f"{{dp}}_{{parts}}"] = [[r["stage"], r["step"], r["loss"]] for r in recs
                                      if "loss" in r and not r.get("heldout")]
print("RESULT" + json.dumps(out))
"""


@pytest.mark.slow
def test_two_devices_and_micro_batches_follow_the_whole_batch(scene_root, tmp_path):
  """lo, ray and hi (with L_empty, density noise and precrop): one device in 4
  micro-batches, and two devices each running its half in 2, log the losses
  of one device's whole-batch step, step for step."""
  env = dict(os.environ, JAX_PLATFORMS="cpu",
             XLA_FLAGS=f"{os.environ.get('XLA_FLAGS', '')} --xla_force_host_platform_device_count=2")
  code = CODE.format(tests=os.path.join(REPO, "tests"), root=scene_root, wd=str(tmp_path))
  res = subprocess.run([sys.executable, "-c", code], cwd=REPO, env=env, capture_output=True,
                       text=True, timeout=600)
  assert res.returncode == 0, res.stderr[-3000:]
  out = json.loads(res.stdout.split("RESULT")[-1])
  # The batch really is split: each device holds half of it.
  assert out["shards"] == [[0.0, 2.0, 4.0, 6.0], [8.0, 10.0, 12.0, 14.0]]
  one = out["losses"]["False_1"]
  assert len(one) == 24
  for other in (out["losses"]["False_4"], out["losses"]["True_2"]):
    assert [r[:2] for r in one] == [r[:2] for r in other]
    np.testing.assert_allclose([r[2] for r in other], [r[2] for r in one], rtol=1e-4)
