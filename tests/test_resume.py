"""Trust in a run: the non-finite guard, kill-and-resume bit-for-bit, workdir checks."""
import json
import os
import signal
import subprocess
import sys
import time

import jax
import jax.numpy as jnp
import numpy as np
import optax
import pytest

from halo_jax import checkpoint, defaults, pipeline, stages
from halo_jax.stages import loop
from halo_jax.stages import step as train_step
from halo_jax.configure import finish  # pylint: disable=g-import-not-at-top

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def _loop_cfg(steps):
  cfg = defaults.base_config().ray  # a stage's config: every field the loop reads
  cfg.update(steps=steps, microbatches=1, lr_init=0.1, lr_final=0.1, max_seconds=0.0,
             log_every=1, checkpoint_every=100, min_steps=0, max_nonfinite=0)
  cfg.eval_every, cfg.eval_every_s = 0, 0.0
  return cfg


def _loss_nan_at_steps_1_and_4(params, data, key, step):
  loss = jnp.sum((params["w"] - data) ** 2)
  return jnp.where((step == 1) | (step == 4), jnp.nan, loss), {}


def test_non_finite_loss_or_gradient_leaves_state_untouched():
  tx = optax.adam(0.1)
  params = {"w": jnp.zeros(3)}
  state = train_step.initial_state(params, tx, step=1)
  before = jax.tree_util.tree_map(np.asarray, state)
  step = train_step.make_step(_loss_nan_at_steps_1_and_4, tx)
  after, loss, _ = step(state, jnp.ones(3), jax.random.PRNGKey(0))
  assert np.isnan(float(loss)) and int(after["skipped"]) == 1 and int(after["step"]) == 2
  for a, b in zip(jax.tree_util.tree_leaves(before["params"]) + jax.tree_util.tree_leaves(
      before["opt_state"]), jax.tree_util.tree_leaves(after["params"]) +
                  jax.tree_util.tree_leaves(after["opt_state"])):
    np.testing.assert_array_equal(a, b)
  # A finite loss with an infinite gradient (sqrt at 0) is skipped as well.
  grad_inf = train_step.make_step(lambda p, d, k, s: (jnp.sqrt(jnp.sum(p["w"] * 0.0)), {}), tx)
  state = train_step.initial_state(params, tx)
  after, loss, _ = grad_inf(state, None, jax.random.PRNGKey(0))
  assert float(loss) == 0.0 and int(after["skipped"]) == 1
  # A finite step does update.
  ok = train_step.make_step(lambda p, d, k, s: (jnp.sum((p["w"] - 1) ** 2), {}), tx)
  after, _, _ = ok(train_step.initial_state(params, tx), None, jax.random.PRNGKey(0))
  assert int(after["skipped"]) == 0 and np.all(np.asarray(after["params"]["w"]) > 0)


def test_skipped_steps_are_counted_in_metrics_log(tmp_path):
  wd = str(tmp_path)
  params, step, info = loop.train("t", _loop_cfg(6), wd, {"w": jnp.zeros(3)},
                                  _loss_nan_at_steps_1_and_4, jnp.ones(3), seed=0)
  assert step == 6 and info["skipped"] == 2
  recs = [json.loads(l) for l in open(os.path.join(wd, "metrics.jsonl"))]
  # Log step n is the n-th step; the loss saw step index n - 1.
  assert [r["skipped"] for r in recs] == [0, 1, 1, 1, 2, 2]
  assert np.all(np.isfinite(np.asarray(params["w"])))


def test_time_budget_stops_after_the_step_that_reaches_it(tmp_path):
  """The loop keeps one step in flight; a budget smaller than any step still
  stops after exactly one, counts its whole time, and checkpoints it."""
  wd = str(tmp_path)
  cfg = _loop_cfg(50)
  cfg.max_seconds = 1e-9
  loss = lambda p, d, k, s: (jnp.sum((p["w"] - d) ** 2), {})
  params, step, info = loop.train("t", cfg, wd, {"w": jnp.zeros(3)}, loss, jnp.ones(3), seed=0)
  assert step == 1 and info["wall_s"] > 0
  np.testing.assert_allclose(np.asarray(params["w"]), 0.1, rtol=1e-5)  # one Adam step of lr 0.1
  mngr = checkpoint.manager(os.path.join(wd, "t", "checkpoints"))
  assert mngr.latest_step() == 1


# ------------------------------------------------------------ kill and resume

RUN_TINY = """
import sys
sys.path.insert(0, {tests!r})
from conftest import tiny_config
from halo_jax import pipeline, stages
from halo_jax.configure import finish
c = tiny_config()
c.data.root = {root!r}
c.hi.encoding.with_lo = True
c.hi.init_from_lo = True
c.eval.lpips = False
for name in ("lo", "ray", "hi"):
  c[name].update(steps=60, checkpoint_every=10, log_every=5)
  c[name].batch_rays = 128
c.lo.eval_every = c.hi.eval_every = 20
pipeline.run(finish(c), {wd!r})
print("DONE")
"""


def _launch(wd, root):
  code = RUN_TINY.format(tests=os.path.join(REPO, "tests"), root=root, wd=wd)
  return subprocess.Popen([sys.executable, "-c", code], cwd=REPO, stdout=subprocess.PIPE,
                          stderr=subprocess.PIPE, text=True)


def _kill_when(proc, path, timeout=240):
  """SIGKILLs proc as soon as `path` exists; returns False if proc ended first."""
  t0 = time.time()
  while not os.path.exists(path):
    if proc.poll() is not None or time.time() - t0 > timeout:
      return False
    time.sleep(0.005)
  proc.send_signal(signal.SIGKILL)
  proc.wait()
  return True


def _final_params(wd, name):
  mngr = checkpoint.manager(os.path.join(wd, name, "final", "params"), max_to_keep=1)
  return mngr.restore(mngr.latest_step())["params"]


@pytest.mark.slow
def test_sigkill_anywhere_then_resume_matches_uninterrupted_run(scene_root, tmp_path):
  ref, killed = str(tmp_path / "ref"), str(tmp_path / "killed")
  p = _launch(ref, scene_root)
  out, err = p.communicate(timeout=600)
  assert p.returncode == 0 and "DONE" in out, err[-3000:]

  # Kill mid-Lo (after its second checkpoint), mid-ray and mid-Hi; resume each time.
  for stage, ckpt in (("lo", 20), ("ray", 50), ("hi", 30)):
    p = _launch(killed, scene_root)
    assert _kill_when(p, os.path.join(killed, stage, "checkpoints", str(ckpt))), (
        f"the run ended before {stage} wrote checkpoint {ckpt}: {p.stderr.read()[-2000:]}")
    assert not os.path.exists(os.path.join(killed, stage, "final", "config.json"))
  p = _launch(killed, scene_root)
  out, err = p.communicate(timeout=600)
  assert p.returncode == 0 and "DONE" in out, err[-3000:]

  for name in ("lo", "ray", "hi"):
    a, b = _final_params(ref, name), _final_params(killed, name)
    for x, y in zip(jax.tree_util.tree_leaves(a), jax.tree_util.tree_leaves(b)):
      np.testing.assert_array_equal(x, y, err_msg=f"stage {name}")
  # Every training record appears once, as in the uninterrupted run.
  def train_records(wd):
    recs = [json.loads(l) for l in open(os.path.join(wd, "metrics.jsonl"))]
    return [(r["stage"], r["step"], r.get("loss")) for r in recs if not r.get("heldout")]
  assert train_records(killed) == train_records(ref)


@pytest.mark.slow
def test_workdir_of_another_config_is_refused(config, scene_root, tmp_path):
  config.data.root = scene_root
  config.stages = "lo"
  wd = str(tmp_path / "run")
  pipeline.run(finish(config), wd)
  # Longer training and other stages are fine in the same workdir...
  config.lo.steps = 8
  stages.check_workdir(finish(config), wd)
  # ...a different model or encoding is not.
  config.lo.encoding.L = 7
  config.lo.model.width = 48
  with pytest.raises(stages.WorkdirMismatch, match=r"config.json: this workdir holds a run made "
                     r"with another config \(2 fields differ: lo.encoding.L: 5 -> 7, "
                     r"lo.model.width: 32 -> 48\)"):
    pipeline.run(finish(config), wd)


def test_progress_bar_of_a_stage_resumed_past_its_budget():
  import ml_collections  # pylint: disable=g-import-not-at-top
  from halo_jax.stages import progress  # pylint: disable=g-import-not-at-top
  cfg = ml_collections.ConfigDict(dict(max_seconds=10.0, batch_rays=64, steps=100))
  bar = progress.ProgressBar("hi", cfg, start_step=50, start_wall_s=12.3)
  bar.advance(51, 0.5, 12.8)
  bar.set_postfix(psnr=20.0)
  assert bar.bar.n == bar.bar.total == 10.0
  bar.close()


def test_a_saved_config_that_predates_a_field_reads_its_default(tmp_path):
  saved = defaults.base_config().to_dict()
  del saved["hi"]["model"]["compute_dtype"]  # a field added after the run
  saved["hi"]["steps"] = 7
  path = str(tmp_path / "config.json")
  with open(path, "w") as f:
    json.dump(saved, f)
  read = checkpoint.read_config(path)
  assert read.hi.steps == 7 and read.hi.model.compute_dtype == "float32"
  assert read.lo.steps == defaults.base_config().lo.steps


@pytest.mark.slow
def test_a_relaunch_restores_finished_stages_and_trains_none_of_them(scene_root, tmp_path,
                                                                      monkeypatch):
  import json  # pylint: disable=import-outside-toplevel
  from halo_jax.stages import loop  # pylint: disable=import-outside-toplevel
  from conftest import pipeline_config  # pylint: disable=import-outside-toplevel
  c = finish(pipeline_config(scene_root, steps=3))
  wd = str(tmp_path / "run")
  first = pipeline.run(c, wd)
  assert list(first) == ["lo", "ray", "hi"]

  def no_training(*args, **kwargs):
    raise AssertionError("a finished stage was compiled and trained again")
  monkeypatch.setattr(loop, "train", no_training)
  again = pipeline.run(c, wd)
  # the same infos, read back: the record a resumed run makes is the first one's
  as_json = lambda infos: json.loads(json.dumps(infos))  # noqa: E731
  assert as_json(again) == as_json(first)
