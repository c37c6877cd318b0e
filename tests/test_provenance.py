"""Provenance: what every info.json and result record says about where it came from."""
import os
import subprocess
import sys

import jax

from halo_jax import provenance


def test_fields_and_values_checked_against_independent_sources(monkeypatch):
  def no_subprocess(*a, **k):
    raise AssertionError(f"the library's provenance ran a command: {a}")
  monkeypatch.setattr(subprocess, "run", no_subprocess)
  monkeypatch.setattr(subprocess, "Popen", no_subprocess)
  p = provenance.collect()
  assert p["versions"]["jax"] == jax.__version__
  assert p["versions"]["python"] == "%d.%d.%d" % sys.version_info[:3]
  assert p["device"]["kind"] == jax.devices()[0].device_kind
  assert p["device"]["count"] == len(jax.devices())
  assert 1 <= p["cpu"]["cores_used"] <= p["cpu"]["cores_total"]
  assert p["cpu"]["model"]
  assert "git" not in p and "matmul_peak_gflops" not in p
  # the command line this process was started with: pytest's, or, in a
  # pytest-xdist worker, the interpreter's `-c` that execnet starts it with
  launched = "-c" if "PYTEST_XDIST_WORKER" in os.environ else "pytest"
  assert launched in p["command"] or "py.test" in p["command"]


def test_code_digest_follows_the_package_files(tmp_path, monkeypatch):
  """The digest hashes the package's .py and .json files by path and content:
  the same files give the same digest, an edit or a new file another."""
  pkg = tmp_path / "halo_jax"
  (pkg / "sub").mkdir(parents=True)
  (pkg / "a.py").write_text("x = 1\n")
  (pkg / "sub" / "t.json").write_text("{}\n")
  (pkg / "notes.txt").write_text("not code\n")
  monkeypatch.setattr(provenance, "_PACKAGE", str(pkg))
  monkeypatch.setattr(provenance.config_files, "shipped_folder", lambda: "")
  digest = lambda: (provenance.code_digest.cache_clear(), provenance.code_digest())[1]  # noqa: E731
  first = digest()
  assert len(first) == 12 and digest() == first
  (pkg / "notes.txt").write_text("changed\n")
  assert digest() == first
  (pkg / "a.py").write_text("x = 2\n")
  second = digest()
  assert second != first
  (pkg / "b.py").write_text("")
  assert digest() != second
  provenance.code_digest.cache_clear()
