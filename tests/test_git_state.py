"""experiments/bench/git_state.py: the commit, code tree and matmul peak the
benchmark adds to its records."""
import subprocess

from experiments.bench import git_state


def test_stamped_provenance_names_this_checkouts_commit():
  p = git_state.collect()
  head = subprocess.run(["git", "-C", git_state.REPO, "rev-parse", "HEAD"],
                        capture_output=True, text=True)
  assert p["matmul_peak_gflops"] > 0
  if head.returncode == 0:
    assert p["git"]["commit"] == head.stdout.strip()
    dirty = subprocess.run(["git", "-C", git_state.REPO, "diff", "--quiet", "HEAD"]).returncode != 0
    assert p["git"]["dirty"] == dirty
  record = git_state.stamp({"psnr": 1.0, "provenance": {"code": {"digest": "x"}}})
  assert record["provenance"]["code"] == {"digest": "x"}
  assert record["provenance"]["git"] == p["git"]


def test_git_state_outside_a_checkout(tmp_path):
  assert git_state.git_state(str(tmp_path)) == {"commit": None, "dirty": None,
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
  clean = git_state.git_state(repo)
  assert not clean["dirty"] and not clean["code_dirty"] and len(clean["code_tree"]) == 12
  (tmp_path / "README.md").write_text("b\n")
  docs = git_state.git_state(repo)
  assert docs["dirty"] and not docs["code_dirty"] and docs["code_tree"] == clean["code_tree"]
  (tmp_path / "halo_jax" / "m.py").write_text("x = 2\n")
  assert git_state.git_state(repo)["code_dirty"]
  git("commit", "-qam", "two")
  assert git_state.git_state(repo)["code_tree"] != clean["code_tree"]


def test_peak_is_measured_once_per_process():
  a = git_state.matmul_peak_gflops()
  assert git_state.matmul_peak_gflops() == a


def test_a_record_names_the_code_its_tool_started_with(monkeypatch):
  """Commits made while a long run trains are not its code: stamp uses the
  state pinned at the tool's start."""
  started = dict(git_state.git_state(), commit="0" * 40)
  monkeypatch.setattr(git_state, "_STARTED", {"git": started})
  record = git_state.stamp({"psnr": 1.0})
  assert record["provenance"]["git"] == started
