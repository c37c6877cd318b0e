"""Runs that cannot progress stop with a reason; user errors are one line and
exit 2; one process per workdir. (Config rules: tests/test_methods.py.)"""
import errno
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

from halo_jax import defaults, pipeline, user_errors, workdir_lock
from halo_jax.stages import loop
from halo_jax.stages import step as train_step
from halo_jax.configure import finish  # pylint: disable=g-import-not-at-top

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def _step(loss_fn, tx, params):
  step = train_step.make_step(lambda p, data, key, step, part=None: (loss_fn(p), {}), tx)
  state = train_step.initial_state(params, tx)
  new, _, _ = step(jax.tree_util.tree_map(jnp.copy, state), None, jax.random.PRNGKey(0))
  return state, new


PARAMS = {"a": jnp.array(3.0), "b": jnp.array([1.0, 2.0])}


@pytest.mark.parametrize("loss_fn, tx, what, leaf", [
    (lambda p: jnp.nan * (p["a"] + p["b"].sum()), optax.sgd(0.1), "loss", None),
    # sqrt at 0: a finite loss with an infinite gradient in leaf 'a'
    (lambda p: jnp.sqrt(jnp.abs(p["a"] - 3.0)) + p["b"].sum(), optax.sgd(0.1), "gradient", 0),
    # a NaN learning rate: loss and gradients finite, the update not (leaf 'a' first)
    (lambda p: (p["a"] ** 2 + p["b"].sum()), optax.sgd(float("nan")), "update", 0),
    # a finite update that overflows the parameter 'b'
    (lambda p: 0.0 * p["a"] - p["b"][1], optax.sgd(1e38), "parameter", 1),
])
def test_guard_names_the_first_non_finite_quantity(loss_fn, tx, what, leaf):
  params = dict(PARAMS, b=jnp.array([1.0, 3e38])) if what == "parameter" else PARAMS
  before, after = _step(loss_fn, tx, params)
  step, got_what, got_leaf = (int(x) for x in after["first_bad"])
  assert (step, train_step.NONFINITE_WHAT[got_what]) == (0, what)
  if leaf is not None:
    assert got_leaf == leaf
  assert int(after["skipped"]) == 1 and int(after["streak"]) == 1
  for k in params:  # the parameters are left as they were
    np.testing.assert_array_equal(after["params"][k], before["params"][k])


def test_a_finite_step_is_taken_and_resets_the_streak():
  before, after = _step(lambda p: p["a"] ** 2 + p["b"].sum(), optax.sgd(0.1), PARAMS)
  assert int(after["skipped"]) == 0 and int(after["streak"]) == 0
  np.testing.assert_allclose(after["params"]["a"], 3.0 - 0.1 * 6.0)


def _train(tmp_path, bad_from, bad_until, max_nonfinite=3):
  cfg = defaults.base_config().lo  # a stage's config: every field the loop reads
  cfg.update(steps=12, batch_rays=1, microbatches=1, lr_init=0.1, lr_final=0.1,
             lr_decay_steps=0, max_seconds=0.0, checkpoint_every=100, log_every=1,
             eval_every=0, eval_every_s=0.0, min_steps=0, max_nonfinite=max_nonfinite)

  def loss_fn(p, data, key, step, part=None):
    bad = (step >= bad_from) & (step < bad_until)
    return jnp.where(bad, jnp.nan, (p["w"] - 1.0) ** 2), {}
  return loop.train("lo", cfg, str(tmp_path), {"w": jnp.array(0.0)}, loss_fn, {}, 0)


def test_a_stage_that_cannot_progress_stops_and_says_why(tmp_path):
  with pytest.raises(loop.NonFiniteError,
                     match=r"stage 'lo': 3 steps in a row up to step 7 were not finite .*"
                     r"lo.max_nonfinite=3.*the first, step 5, had a non-finite loss"):
    _train(tmp_path, 4, 100)


def test_isolated_non_finite_steps_are_skipped(tmp_path):
  params, step, info = _train(tmp_path, 4, 6)   # two bad steps, under the limit of 3
  assert step == 12 and info["skipped"] == 2


def _cli(args, tmp_path):
  cmd = [sys.executable, "-m", "halo_jax.cli.train", "--config=configs/default.py",
         f"--workdir={tmp_path / 'run'}", "--config.stages=lo", *args]
  return subprocess.run(cmd, cwd=REPO, capture_output=True, text=True, timeout=300)


@pytest.mark.parametrize("args, message", [
    (["--config.lo.lr_init=nan"], "error: lo.lr_init=nan: must be a positive number"),
    (["--config.lo.batch_rays=0"], "error: lo.batch_rays=0: must be a positive integer"),
    (["--config.stages=lo,rays"], "error: config.stages='lo,rays': each stage must be one of"),
])
def test_bad_config_is_one_line_and_exit_2(args, message, tmp_path):
  res = _cli(args, tmp_path)
  assert res.returncode == 2, res.stderr[-2000:]
  assert message in res.stderr and "Traceback" not in res.stderr
  assert not (tmp_path / "run").exists()


def test_table_shows_a_dash_for_metrics_a_stage_does_not_have():
  text = pipeline.table({"ray": {"step": 3, "wall_s": 1.0},
                     "hi": {"step": 4, "wall_s": 2.0, "eval": {"psnr": 20.0, "ssim": 0.5},
                            "learned": {"verdict": "learned"}}})
  ray, hi = text.splitlines()[1:]
  assert ray.split()[-4:] == ["-", "-", "-", "-"] and "nan" not in text
  assert hi.split()[-4:] == ["20.00", "0.500", "-", "learned"]


# A Lo-NeRF small enough that a launch spends its time compiling, not training.
TINY_LO = ["--config.lo.model.width=16", "--config.lo.model.depth=2", "--config.lo.batch_rays=64",
           "--config.lo.microbatches=1", "--config.lo.sampler.num_samples=8",
           "--config.data.test_views=r_0", "--config.protocol=steps", "--config.budget_s=0", "--config.eval.lpips=False"]

HOLD = ("import sys, time; from halo_jax import workdir_lock\n"
        "with workdir_lock.hold(sys.argv[1]):\n  print('held', flush=True); time.sleep(600)\n")


def test_a_second_launch_is_refused_and_kill_9_leaves_nothing_stale(config, tmp_path):
  wd = str(tmp_path / "run")
  holder = subprocess.Popen([sys.executable, "-c", HOLD, wd], cwd=REPO, stdout=subprocess.PIPE,
                            text=True)
  try:
    assert holder.stdout.readline().strip() == "held"
    with pytest.raises(workdir_lock.WorkdirLocked, match=f"in use by pid {holder.pid} on host "):
      pipeline.run(finish(config), wd)
    res = subprocess.run([sys.executable, "-m", "halo_jax.cli.compare", "--config=configs/default.py",
                          f"--workdir={wd}"], cwd=REPO, capture_output=True, text=True,
                         timeout=300)
    assert res.returncode == 2 and f"pid {holder.pid}" in res.stderr
    assert "Traceback" not in res.stderr
  finally:
    holder.send_signal(signal.SIGKILL)
    holder.wait()
  with workdir_lock.hold(wd):  # the kernel released it with the process
    with workdir_lock.hold(wd):  # and one process may nest holds
      pass


def test_an_unwritable_workdir_is_one_line_naming_it(tmp_path, capsys):
  blocker = tmp_path / "a_file"
  blocker.write_text("")
  wd = str(blocker / "run")  # below a regular file: no folder can be made there, even by root
  with pytest.raises(SystemExit) as e:
    with user_errors.reported():
      with workdir_lock.hold(wd):
        pass
  assert e.value.code == 2
  err = capsys.readouterr().err
  assert err.count("\n") == 1 and err.startswith(f"error: {wd}: cannot write")


def test_a_full_disk_mid_run_is_one_line(capsys):
  with pytest.raises(SystemExit) as e:
    with user_errors.reported():
      raise OSError(errno.ENOSPC, "No space left on device", "/w/hi/checkpoints/7")
  assert e.value.code == 2
  assert capsys.readouterr().err == (
      "error: /w/hi/checkpoints/7: cannot write (No space left on device); free space there "
      "or use another --workdir (a relaunch resumes from the last checkpoint)\n")


@pytest.mark.slow
def test_sigterm_saves_a_checkpoint_and_the_relaunch_logs_every_step_once(tmp_path):
  """A scheduler's pre-emption: one line, exit 143, the step it stopped at
  checkpointed; the same command again finishes with every step logged once."""
  wd = tmp_path / "run"
  args = ["--config.lo.steps=2000", "--config.lo.log_every=1",
          "--config.lo.checkpoint_every=100000"]
  cmd = [sys.executable, "-m", "halo_jax.cli.train", "--config=configs/default.py",
         f"--workdir={wd}", "--config.stages=lo", *TINY_LO, *args]
  proc = subprocess.Popen(cmd, cwd=REPO, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                          text=True)
  log = wd / "metrics.jsonl"
  while not (log.exists() and log.stat().st_size) and proc.poll() is None:
    time.sleep(0.1)
  proc.send_signal(signal.SIGTERM)
  _, err = proc.communicate(timeout=300)
  assert proc.returncode == 143, err[-2000:]
  lines = [line for line in err.replace("\r", "\n").splitlines() if line.startswith("error:")]
  assert len(lines) == 1 and "Traceback" not in err
  stopped = int(lines[0].split(" at step ")[1].split(",")[0])
  assert 0 < stopped < 2000 and (wd / "lo" / "checkpoints" / str(stopped)).is_dir()
  assert subprocess.run(cmd, cwd=REPO, capture_output=True, timeout=300).returncode == 0
  steps = [r["step"] for r in map(json.loads, log.read_text().splitlines())
           if r.get("stage") == "lo" and "loss" in r]
  assert steps == list(range(1, 2001))
