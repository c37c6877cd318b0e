"""The same figures on a slow machine as on a fast one: the smoke suite's
budgeted runs, alone and beside a process that halves their speed, train
the same steps and score the same PSNR (halo_jax/protocol.py)."""
import glob
import json
import os
import subprocess
import sys
import time

import pytest

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
HOG = "while True:\n  pass\n"


def _pin(core):
  return lambda: os.sched_setaffinity(0, {core})


def _smoke(out, core):
  """Runs the smoke suite into `out` on one core; {run: record}."""
  env = dict(os.environ, HALO_DATA=str(out / "no_data"))
  res = subprocess.run(
      [sys.executable, "-m", "experiments.bench.benchmark", "--suite=smoke",
       f"--results={out / 'results'}", f"--scratch={out / 'scratch'}"],
      cwd=REPO, env=env, capture_output=True, text=True, timeout=900, preexec_fn=_pin(core))
  assert res.returncode == 0, res.stderr[-3000:]
  records = {}
  for path in glob.glob(str(out / "results" / "smoke" / "budget" / "*" / "*" / "seed*.json")):
    with open(path) as f:
      r = json.load(f)
    records[f"{r['scene']}/{r['method']}/seed{r['seed']}"] = r
  return records


@pytest.mark.slow
@pytest.mark.skipif(not hasattr(os, "sched_setaffinity"), reason="needs CPU pinning")
def test_the_smoke_suite_scores_the_same_beside_a_process_that_halves_its_speed(tmp_path):
  core = sorted(os.sched_getaffinity(0))[-1]
  alone = _smoke(tmp_path / "alone", core)
  hog = subprocess.Popen([sys.executable, "-c", HOG], preexec_fn=_pin(core))
  try:
    time.sleep(0.5)
    started = time.time()
    shared = _smoke(tmp_path / "shared", core)
    # the premise: the busy process took a good share of that core meanwhile
    with open(f"/proc/{hog.pid}/stat") as f:
      hog_s = sum(int(x) for x in f.read().rsplit(")", 1)[1].split()[11:13]) / os.sysconf(
          "SC_CLK_TCK")
    assert hog_s > 0.25 * (time.time() - started), hog_s
  finally:
    hog.kill()
    hog.wait()
  assert set(alone) == set(shared) == {"spheres/nerf_tuned/seed0", "spheres/halo/seed0"}
  for run in alone:
    a, s = alone[run], shared[run]
    assert a["protocol"]["kind"] == "budget" and not a["protocol"]["measured"], run
    assert {n: st["step"] for n, st in a["stages"].items()} == {
        n: st["step"] for n, st in s["stages"].items()}, run
    assert abs(a["psnr"] - s["psnr"]) < 0.01, (run, a["psnr"], s["psnr"])
    # the front's points fall at the same steps
    assert [(p["at_s"], p["step"]) for p in a["front"]] == [
        (p["at_s"], p["step"]) for p in s["front"]], run
    for pa, ps in zip(a["front"], s["front"]):
      assert abs(pa["psnr"] - ps["psnr"]) < 0.01, (run, pa, ps)
