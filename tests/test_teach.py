"""L_teach (stages/teach.py): where Lo counts as sure, the weight's fall over
Hi's run, the neighbour rays, and the term on a real run (halo+teach)."""
import json
import os

import jax.numpy as jnp
import ml_collections
import numpy as np
import pytest

from halo_jax import defaults, pipeline
from halo_jax.configs import blender, dnerf, llff
from halo_jax.rays import Rays
from halo_jax.stages import teach, terms
from conftest import editable, tiny_config
from halo_jax.configure import finish  # pylint: disable=g-import-not-at-top


def test_lo_is_sure_where_opaque_on_the_ray_and_its_neighbour_at_one_depth():
  acc = jnp.array([0.99, 0.99, 0.5, 0.99])
  acc_near = jnp.array([0.99, 0.99, 0.99, 0.9])
  depth = jnp.array([0.30, 0.30, 0.30, 0.30])
  depth_near = jnp.array([0.31, 0.40, 0.30, 0.30])
  sure = teach.confident(acc, acc_near, depth, depth_near, acc_min=0.95, depth_tol=0.02)
  np.testing.assert_array_equal(np.asarray(sure), [True, False, False, False])


def test_the_weight_falls_linearly_to_zero_at_the_stages_last_step():
  cfg = ml_collections.ConfigDict(dict(steps=6000, stop_at_step=0, budget_steps=400,
                                       teach=dict(weight=0.1)))
  w = [float(teach.weight(cfg, jnp.asarray(s))) for s in (0, 100, 200, 400, 1000)]
  np.testing.assert_allclose(w, [0.1, 0.075, 0.05, 0.0, 0.0], rtol=1e-6)


def test_a_neighbour_is_later_in_time_or_turned_by_the_jitter():
  t = ml_collections.ConfigDict(dict(time_step=0.02, jitter=0.01))
  o = np.zeros((64, 3), np.float32)
  d = np.random.default_rng(0).normal(size=(64, 3)).astype(np.float32)
  d /= np.linalg.norm(d, axis=-1, keepdims=True)
  import jax  # pylint: disable=import-outside-toplevel
  later = teach._neighbours(Rays(o, d, np.full((64, 1), 0.99, np.float32)),  # pylint: disable=protected-access
                            jax.random.PRNGKey(0), t)
  np.testing.assert_array_equal(later.dirs, d)
  np.testing.assert_allclose(later.times, 1.0)  # clipped to the scene's time range
  turned = teach._neighbours(Rays(o, d, None), jax.random.PRNGKey(0), t)  # pylint: disable=protected-access
  np.testing.assert_allclose(np.linalg.norm(turned.dirs, axis=-1), 1.0, rtol=1e-6)
  np.testing.assert_allclose(np.arccos(np.clip((turned.dirs * d).sum(-1), -1, 1)), 0.01,
                             atol=2e-4)


def test_halo_teach_is_halo_plus_one_term_on_hi_and_only_on_sphere_rays():
  ours = editable(dnerf.get_config("hook_cpu"), "halo+teach")
  assert ours.hi.teach.to_dict() == dict(defaults.teach_section().to_dict(), weight=0.1)
  assert [n for n, _ in terms.active_terms(ours.hi)][-1] == "teach"
  plain = editable(dnerf.get_config("hook_cpu"), "halo")
  assert "teach" not in [n for n, _ in terms.active_terms(plain.hi)]
  ours.hi.teach.weight = 0.0
  ours.method = "halo"  # HALO and the one weight (the step table's entries are keyed by method)
  assert finish(ours).to_dict() == finish(plain).to_dict()
  assert editable(blender.get_config("lego_8view_cpu"), "halo+teach").hi.teach.weight == 0.1
  assert editable(llff.get_config("fern_4view_cpu"), "halo+teach").hi.teach.weight == 0.0


def test_a_stage_with_the_term_off_keeps_its_step_table_key():
  from halo_jax import step_table  # pylint: disable=import-outside-toplevel
  ours = editable(dnerf.get_config("hook_cpu"), "halo+teach")
  plain = editable(dnerf.get_config("hook_cpu"), "halo")
  del plain.hi["teach"]  # the stage as it was before the term existed
  digest = lambda c: step_table.key(c, "hi").rsplit("|", 1)[1]  # noqa: E731
  assert digest(ours) != digest(plain)
  ours.hi.teach.weight = 0.0
  assert digest(ours) == digest(plain)


@pytest.mark.slow
def test_l_teach_holds_hi_to_lo_where_lo_is_sure(scene_root, tmp_path):
  # The same run twice, the term on (weight 1) and effectively off (1e-9,
  # so that its value is still logged): Hi ends nearer Lo on Lo's sure rays
  # with it, and still fits its training views.
  c = tiny_config("halo+teach")
  c.data.root = scene_root
  c.eval.lpips = False
  c.lo.update(steps=80, lr_init=5e-3, lr_final=5e-3)
  c.ray.update(steps=20)
  c.hi.update(steps=60, log_every=5, lr_init=5e-3, lr_final=5e-3)
  c.hi.teach.update(num_rays=64, num_samples=16, bank_rays=4096, acc_min=0.5, depth_tol=0.05)
  teach_at, wd = {}, {}
  for weight in (1.0, 1e-9):
    c.hi.teach.weight = weight
    wd[weight] = str(tmp_path / f"w{weight}")
    infos = pipeline.run(finish(c), wd[weight])
    assert infos["hi"]["skipped"] == 0
    log = [json.loads(line) for line in open(os.path.join(wd[weight], "metrics.jsonl"))]
    teach_at[weight] = [r["teach"] for r in log if r.get("stage") == "hi" and "teach" in r]
  assert len(teach_at[1.0]) >= 3 and all(np.isfinite(teach_at[1.0]))
  assert np.mean(teach_at[1.0][-3:]) < np.mean(teach_at[1e-9][-3:])
