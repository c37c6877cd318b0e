"""Every tool in experiments/ runs as a module of the package (`python -m
experiments.<tool>`, no import-path edits) and answers --help with its usage,
without running: its imports resolve and its top level runs, so a tool whose
library moved fails here, not in a user's hands."""
import ast
import glob
import os
import subprocess
import sys

import pytest

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
TOOLS = sorted(os.path.basename(p)[:-3] for p in glob.glob(os.path.join(REPO, "experiments", "*.py"))
               if not p.endswith("__init__.py"))


@pytest.mark.parametrize("tool", TOOLS)
def test_the_tool_answers_help_with_its_usage(tool, tmp_path):
  # run from a folder outside the clone, with the clone on the path as an
  # installed package would be: nothing may be written where it runs
  env = dict(os.environ, PYTHONPATH=REPO)
  res = subprocess.run([sys.executable, "-m", f"experiments.{tool}", "--help"], cwd=tmp_path,
                       env=env, capture_output=True, text=True, timeout=120)
  out = res.stdout + res.stderr
  assert res.returncode in (0, 1) and "Traceback" not in out, out[-2000:]  # absl's --help exits 1
  # a wrapper prints the usage of the module it runs (experiments/bench/<tool>.py)
  inner = os.path.join(REPO, "experiments", "bench", f"{tool}.py")
  module = f"experiments.bench.{tool}" if os.path.exists(inner) else f"experiments.{tool}"
  path = os.path.join(REPO, *module.split(".")) + ".py"
  with open(path) as f:
    first = ast.get_docstring(ast.parse(f.read())).splitlines()[0]
  assert first[:40] in out, out[:500]
  assert os.listdir(tmp_path) == []


def test_no_tool_edits_the_import_path():
  for folder in ("experiments", "halo_jax"):
    for path in glob.glob(os.path.join(REPO, folder, "**", "*.py"), recursive=True):
      with open(path) as f:
        edits = "sys.path" in f.read()
      assert not edits, path
