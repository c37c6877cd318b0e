"""Every script in experiments/ loads: its imports resolve and its top level
runs (as a module, so its main does not), so a script whose library moved
fails here, not in a user's hands."""
import glob
import os
import subprocess
import sys

import pytest

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SCRIPTS = sorted(p for p in glob.glob(os.path.join(REPO, "experiments", "*.py"))
                 if not p.endswith("__init__.py"))
LOAD = ("import importlib.util, sys; "
        "spec = importlib.util.spec_from_file_location('script_under_test', sys.argv[1]); "
        "spec.loader.exec_module(importlib.util.module_from_spec(spec))")


@pytest.mark.parametrize("script", SCRIPTS, ids=os.path.basename)
def test_the_script_loads(script):
  res = subprocess.run([sys.executable, "-c", LOAD, script], cwd=REPO, capture_output=True,
                       text=True, timeout=120)
  assert res.returncode == 0, res.stderr[-2000:]
