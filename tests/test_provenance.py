"""Provenance: what every info.json and result record says about where it came from."""
import os
import subprocess
import sys

import jax

from halo_jax import provenance


def test_fields_and_values_checked_against_independent_sources():
  p = provenance.collect()
  assert p["versions"]["jax"] == jax.__version__
  assert p["versions"]["python"] == "%d.%d.%d" % sys.version_info[:3]
  assert p["device"]["kind"] == jax.devices()[0].device_kind
  assert p["device"]["count"] == len(jax.devices())
  assert 1 <= p["cpu"]["cores_used"] <= p["cpu"]["cores_total"]
  assert p["cpu"]["model"]
  assert p["matmul_peak_gflops"] > 0
  # the command line this process was started with: pytest's, or, in a
  # pytest-xdist worker, the interpreter's `-c` that execnet starts it with
  launched = "-c" if "PYTEST_XDIST_WORKER" in os.environ else "pytest"
  assert launched in p["command"] or "py.test" in p["command"]
  repo = provenance._REPO  # pylint: disable=protected-access
  head = subprocess.run(["git", "-C", repo, "rev-parse", "HEAD"], capture_output=True,
                        text=True)
  if head.returncode == 0:
    assert p["git"]["commit"] == head.stdout.strip()
    dirty = subprocess.run(["git", "-C", repo, "diff", "--quiet", "HEAD"]).returncode != 0
    assert p["git"]["dirty"] == dirty


def test_git_state_outside_a_checkout(tmp_path):
  assert provenance.git_state(str(tmp_path)) == {"commit": None, "dirty": None,
                                                 "code_tree": None, "code_dirty": None}


def test_git_state_tells_a_code_change_from_a_docs_change(tmp_path):
  import subprocess  # pylint: disable=g-import-not-at-top
  repo = str(tmp_path)
  git = lambda *a: subprocess.run(["git", "-C", repo, *a], check=True, capture_output=True)  # noqa: E731
  git("init", "-q")
  git("config", "user.email", "t@t")
  git("config", "user.name", "t")
  (tmp_path / "halo_jax").mkdir()
  (tmp_path / "halo_jax" / "m.py").write_text("x = 1\n")
  (tmp_path / "README.md").write_text("a\n")
  git("add", "-A")
  git("commit", "-qm", "one")
  clean = provenance.git_state(repo)
  assert not clean["dirty"] and not clean["code_dirty"] and len(clean["code_tree"]) == 12
  (tmp_path / "README.md").write_text("b\n")
  docs = provenance.git_state(repo)
  assert docs["dirty"] and not docs["code_dirty"] and docs["code_tree"] == clean["code_tree"]
  (tmp_path / "halo_jax" / "m.py").write_text("x = 2\n")
  assert provenance.git_state(repo)["code_dirty"]
  git("commit", "-qam", "two")
  assert provenance.git_state(repo)["code_tree"] != clean["code_tree"]


def test_peak_is_measured_once_per_process():
  a = provenance.matmul_peak_gflops()
  assert provenance.matmul_peak_gflops() == a
