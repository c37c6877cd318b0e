"""Two processes joined by jax.distributed on this machine (CPU, gloo): the
same loss trajectory as one process, one writer, and a lost peer ends the job
instead of hanging it. docs/throughput.md (data parallelism) says how to launch on a
cluster."""
import json
import os
import socket
import subprocess
import sys
import time

import numpy as np
import pytest

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

WORKER = """
import json, sys
sys.path.insert(0, {tests!r})
from conftest import pipeline_config
from halo_jax import parallel, pipeline, user_errors
from halo_jax.configure import finish  # pylint: disable=g-import-not-at-top
pid, num = int(sys.argv[1]), int(sys.argv[2])
c = pipeline_config({root!r}, {steps})
c.eval.lpips = False
for name in ("lo", "ray", "hi"):
  c[name].update(checkpoint_every=4, eval_every=0)
if num > 1:
  c.parallel.update(multihost=True, data_parallel=True, coordinator="127.0.0.1:{port}",
                    num_processes=num, process_id=pid, heartbeat_s=10)
parallel.initialize(c.parallel)
with user_errors.reported():
  infos = pipeline.run(finish(c), {wd!r})
print("DONE", json.dumps({{k: v["step"] for k, v in infos.items()}}), flush=True)
"""


def free_port():
  with socket.socket() as s:
    s.bind(("127.0.0.1", 0))
    return s.getsockname()[1]


def launch(scene_root, wd, pid, num, steps=6, port=0):
  code = WORKER.format(tests=os.path.join(REPO, "tests"), root=scene_root, wd=wd, steps=steps,
                       port=port)
  env = dict(os.environ, JAX_PLATFORMS="cpu",  # one device per process: no forced count
             XLA_FLAGS=os.environ.get("XLA_FLAGS", "").replace(
                 "--xla_force_host_platform_device_count=2", ""))
  return subprocess.Popen([sys.executable, "-c", code, str(pid), str(num)], cwd=REPO, env=env,
                          stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def losses(wd):
  recs = [json.loads(line) for line in open(os.path.join(wd, "metrics.jsonl"))]
  return [(r["stage"], r["step"], r["loss"]) for r in recs if "loss" in r]


@pytest.mark.slow
def test_two_processes_follow_one_and_only_process_0_writes(scene_root, tmp_path):
  one = launch(scene_root, str(tmp_path / "one"), 0, 1)
  out, err = one.communicate(timeout=600)
  assert one.returncode == 0, err[-3000:]
  port, wd = free_port(), str(tmp_path / "two")
  procs = [launch(scene_root, wd, i, 2, port=port) for i in range(2)]
  outs = [p.communicate(timeout=900) for p in procs]
  for p, (out, err) in zip(procs, outs):
    assert p.returncode == 0, err[-3000:]
    assert "DONE" in out
  a, b = losses(str(tmp_path / "one")), losses(wd)
  # one writer: every record once, in the single process's order
  assert [r[:2] for r in a] == [r[:2] for r in b] and len(a) == 18
  np.testing.assert_allclose([r[2] for r in b], [r[2] for r in a], rtol=1e-4)
  for name in ("lo", "ray", "hi"):
    assert os.path.exists(os.path.join(wd, name, "final", "config.json"))


@pytest.mark.slow
def test_a_lost_process_ends_the_other_with_an_error(scene_root, tmp_path):
  port, wd = free_port(), str(tmp_path / "run")
  procs = [launch(scene_root, wd, i, 2, steps=100000, port=port) for i in range(2)]
  log = os.path.join(wd, "metrics.jsonl")
  t0 = time.time()
  while not (os.path.exists(log) and os.path.getsize(log) > 0) and time.time() - t0 < 300:
    time.sleep(1)
  assert os.path.exists(log), "the job never started training"
  procs[1].kill()
  t_kill = time.time()
  _, err = procs[0].communicate(timeout=180)
  assert time.time() - t_kill < 60, "the surviving process hung"
  # In a step's all-reduce the survivor gets a Python error: our one line,
  # exit 3. Waiting at a checkpoint's barrier it is ended by JAX's
  # distributed service once the peer missed heartbeat_s of heartbeats: an
  # abort with JAX's own message (nothing in Python to catch). Finishing a
  # checkpoint's save, it gets our line too, after orbax has logged the
  # failed finalize thread's traceback (orbax's log, not an uncaught error).
  if procs[0].returncode == 3:
    assert "another process of the job has probably died" in err, err[-3000:]
    ours = err[err.index("another process of the job has probably died"):]
    assert "Traceback" not in ours, err[-3000:]  # nothing uncaught after our line
    before = err[:err.index("another process of the job has probably died")]
    assert "Traceback" not in before or "orbax/checkpoint" in before, err[-3000:]
  else:
    assert procs[0].returncode in (-6, 134), err[-3000:]
    assert "another task died" in err, err[-3000:]
