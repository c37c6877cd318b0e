"""experiments/rerun_fronts.py: which scenes are already on the current code, and
what a scene's rerun writes and commits."""
import json
import os
import subprocess

from experiments import rerun_fronts

OLD = "0123456789abcdef0123456789abcdef01234567"   # not in this repository:
NEW = "fedcba9876543210fedcba9876543210fedcba98"   # each names its own version


def _write(root, scene, method, seed, commit, front=True):
  path = os.path.join(root, rerun_fronts.SUITE_DIR, scene, method, f"seed{seed}.json")
  os.makedirs(os.path.dirname(path), exist_ok=True)
  rec = {"provenance": {"git": {"commit": commit, "dirty": False}},
         "front": [{"at_s": 15.0, "psnr": 10.0}] if front else []}
  with open(path, "w") as f:
    json.dump(rec, f)


def test_a_scene_is_up_to_date_only_when_every_pair_record_has_a_front_of_this_code(tmp_path):
  root, methods, seeds = str(tmp_path), ["nerf_tuned", "halo"], ["0", "1"]
  for m in methods:
    for s in seeds:
      _write(root, "a", m, s, NEW)
  assert rerun_fronts.up_to_date(root, "a", methods, seeds, "fedcba9")
  assert not rerun_fronts.up_to_date(root, "a", methods, seeds, "0123456")  # other code
  _write(root, "a", "halo", "1", OLD)                                       # one record older
  assert not rerun_fronts.up_to_date(root, "a", methods, seeds, "fedcba9")
  _write(root, "a", "halo", "1", NEW, front=False)                          # one without a front
  assert not rerun_fronts.up_to_date(root, "a", methods, seeds, "fedcba9")
  assert not rerun_fronts.up_to_date(root, "b", methods, seeds, "fedcba9")  # nothing at all


class _Finished:
  def wait(self):
    return 0


def test_run_scene_replaces_the_pair_records_in_the_repository_and_commits_only_them(
    tmp_path, monkeypatch):
  """run_scene with a stand-in for benchmark.py: the records it writes under
  `work` reach the repository's results/ and one commit holding only them."""
  repo, work = str(tmp_path / "repo"), str(tmp_path / "work")
  subprocess.run(["git", "init", "-q", repo], check=True)
  for m in ("nerf_tuned", "halo", "freenerf"):
    _write(repo, "a", m, "0", OLD)
  with open(os.path.join(repo, "other.txt"), "w") as f:
    f.write("staged elsewhere")
  git = ["git", "-C", repo, "-c", "user.name=t", "-c", "user.email=t@t"]
  subprocess.run(git + ["add", "."], check=True)
  subprocess.run(git + ["commit", "-q", "-m", "old"], check=True)
  os.makedirs(os.path.join(work, "scratch", "cpu", "time", "a", "halo", "seed0"))
  launched = []

  def launch(work_dir, scene, method, core, seeds):
    assert not os.path.exists(os.path.join(work_dir, "scratch", "cpu", "time", scene, method,
                                           "seed0"))      # a killed scene starts afresh
    assert not os.path.exists(os.path.join(work_dir, rerun_fronts.SUITE_DIR, scene, method,
                                           "seed0.json"))  # removed: benchmark.py reruns it
    launched.append((method, core))
    for seed in seeds:
      _write(work_dir, scene, method, seed, NEW)
    return _Finished()

  with open(os.path.join(repo, "other.txt"), "w") as f:
    f.write("changed, staged, not the scene's")
  subprocess.run(git + ["add", "other.txt"], check=True)
  for var in ("GIT_AUTHOR_NAME", "GIT_AUTHOR_EMAIL", "GIT_COMMITTER_NAME", "GIT_COMMITTER_EMAIL"):
    monkeypatch.setenv(var, "t@t")
  rerun_fronts.run_scene("a", ["nerf_tuned", "halo"], "fedcba9", work=work, seeds=["0"],
                         cores={"nerf_tuned": 0, "halo": 1}, repo=repo, launch=launch)
  assert launched == [("nerf_tuned", 0), ("halo", 1)]
  assert rerun_fronts.up_to_date(repo, "a", ["nerf_tuned", "halo"], ["0"], "fedcba9")
  assert not rerun_fronts.up_to_date(repo, "a", ["freenerf"], ["0"], "fedcba9")  # untouched
  changed = subprocess.run(git + ["show", "--name-only", "--format=", "HEAD"], check=True,
                           capture_output=True, text=True).stdout.split()
  assert sorted(changed) == [f"{rerun_fronts.SUITE_DIR}/a/{m}/seed0.json"
                             for m in ("halo", "nerf_tuned")]


def test_only_regex_selects_exactly_the_scene_method_and_seeds_of_the_suite():
  from experiments import benchmark, suites  # pylint: disable=import-outside-toplevel
  for method in ("halo+unseen", "halo+freenerf", "nerf_tuned"):
    picked = [(s.name, m, seed) for s, m, seed in
              benchmark.plan(suites.CPU, rerun_fronts.only_regex("lego_8view", method, ["0", "1"]))]
    assert picked == [("lego_8view", method, 0), ("lego_8view", method, 1)]
