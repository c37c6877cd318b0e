"""Adding a method is one new module and its registry line: a toy method,
written to a file outside the package, runs through halo-train, halo-compare
and the benchmark's smoke suite with no other file edited."""
import dataclasses
import json
import os
import subprocess
import sys

import pytest

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

TOY = '''
from halo_jax.methods import METHODS, base, nerf_tuned


METHOD = base.Method("a toy: nerf_tuned with 8 samples a ray",
                     base.on_top_of(nerf_tuned.METHOD,
                                    base.every_kind({"hi.sampler.num_samples": 8})))
METHODS.register("toy", METHOD)
'''

TINY = ["--config=configs/default.py", "--config.data.procedural_size=32",
        "--config.data.test_views=r_0", "--config.protocol=steps", "--config.budget_s=0",
        "--config.hi.steps=4", "--config.hi.model.width=16", "--config.hi.model.depth=2",
        "--config.hi.batch_rays=64", "--config.eval.lpips=False", "--config.hi.log_every=1"]


def _cli(tmp_path, module, *args):
  code = f"import toy_method; from halo_jax.cli import {module}; {module}.cli()"
  env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(tmp_path), REPO]))
  return subprocess.run([sys.executable, "-c", code, *args], cwd=REPO, env=env,
                        capture_output=True, text=True, timeout=600)


@pytest.mark.slow
def test_a_toy_method_runs_through_train_compare_and_the_smoke_suite(tmp_path, monkeypatch):
  (tmp_path / "toy_method.py").write_text(TOY)
  scenes = str(tmp_path / "scenes")
  tiny = TINY + [f"--config.data.root={scenes}"]
  out = _cli(tmp_path, "train", f"--workdir={tmp_path / 'train'}", "--method=toy", *tiny)
  assert out.returncode == 0, out.stderr[-2000:]
  with open(tmp_path / "train" / "config.json") as f:
    assert json.load(f)["hi"]["sampler"]["num_samples"] == 8
  out = _cli(tmp_path, "compare", f"--workdir={tmp_path / 'compare'}", "--methods=toy", *tiny)
  assert out.returncode == 0, out.stderr[-2000:]
  assert "| toy |" in out.stdout
  # the benchmark's smoke suite, in this process: the module imported is the
  # whole change
  from experiments.bench import benchmark, suites  # pylint: disable=import-outside-toplevel
  from halo_jax.methods import METHODS  # pylint: disable=import-outside-toplevel
  # the registry as it was once the test ends (other tests list every method)
  monkeypatch.setattr(METHODS, "_entries", dict(METHODS._entries))  # pylint: disable=protected-access
  if "toy" not in METHODS.names():   # (registered for the session under HALO_TOY_METHOD)
    exec(compile(TOY, str(tmp_path / "toy_method.py"), "exec"), {})  # pylint: disable=exec-used
  scene = dataclasses.replace(suites.SMOKE.scenes[0], methods=("toy",))
  results, scratch = str(tmp_path / "results"), str(tmp_path / "scratch")
  r = benchmark.run_one("smoke", suites.SMOKE, scene, "toy", 0, "budget", results, scratch)
  assert r["method"] == "toy" and r["resolved_config"]["hi"]["sampler"]["num_samples"] == 8
  assert os.path.exists(benchmark.result_path(results, "smoke", "budget", scene, "toy", 0))
