"""experiments/throughput_report.py: result file paths, the comparison with the
measurement committed before, and the commits named as having moved it."""
import os
import subprocess

import pytest

from experiments.bench import run_file, throughput_report


def _record(time_utc, commit, ms, peak=400.0, dirty=False, overrides=None):
  steps = {name: {"s_per_step": t / 1e3, "rays_per_s": 1024 / (t / 1e3),
                  "samples_per_s": 32 * 1024 / (t / 1e3), "gflops": 10.0,
                  "gflops_per_s": 10.0 / (t / 1e3), "share_of_peak": 10.0 / (t / 1e3) / peak}
           for name, t in ms.items()}
  prov = {"time_utc": time_utc, "git": {"commit": commit, "dirty": dirty},
          "device": {"backend": "cpu", "kind": "cpu", "count": 1, "processes": 1},
          "cpu": {"model": "AMD EPYC 9B14", "cores_used": 2, "cores_total": 2},
          "versions": {"jax": "0.0"}}
  return {"config": "configs/blender.py:lego_8view_cpu", "overrides": overrides or {},
          "flags": {"repeats": 10, "rounds": 3, "peak_n": 2048}, "peak_gflops": peak,
          "device": "cpu", "steps": steps, "provenance": prov}


def test_result_path_names_config_machine_time_and_commit():
  r = _record("2026-11-25T06:00:00Z", "abcdef0123", {"lo": 50.0})
  path = throughput_report.result_path("/r", r)
  assert path == "/r/blender-lego_8view_cpu/cpu-amd-epyc-9b14-2c/20261125T060000Z_abcdef0.json"
  r["provenance"]["git"]["dirty"] = True
  r["overrides"] = {"lo.microbatches": "128"}
  path = throughput_report.result_path("/r", r)
  assert path.endswith("_abcdef0-dirty.json")
  series = path.split("/")[2]
  assert series.startswith("blender-lego_8view_cpu+") and len(series) == len("blender-lego_8view_cpu+") + 6
  r["provenance"]["device"] = {"backend": "gpu", "kind": "NVIDIA H100 80GB HBM3"}
  assert "/gpu-nvidia-h100-80gb-hbm3/" in throughput_report.result_path("/r", r)


def test_compare_calls_moves_beyond_the_noise_band():
  old = _record("2026-11-24T00:00:00Z", None, {"lo": 50.0, "hi": 100.0, "render": 200.0})
  new = _record("2026-11-25T00:00:00Z", None, {"lo": 40.0, "hi": 102.0, "render": 230.0,
                                               "ray": 5.0})
  c = throughput_report.compare(old, new)
  assert list(c) == ["lo", "hi", "render"]  # 'ray' is new: nothing to compare it with
  assert c["lo"]["ratio"] == pytest.approx(0.8) and c["lo"]["moved"] == "faster"
  assert c["hi"]["moved"] == "" and c["render"]["moved"] == "slower"
  assert c["lo"]["new_share"] == pytest.approx(10.0 / 0.04 / 400.0)


def test_page_from_files_compares_the_newest_with_the_one_before(tmp_path):
  root = str(tmp_path / "throughput")
  for r in (_record("2026-11-23T00:00:00Z", None, {"lo": 60.0, "hi": 100.0}),
            _record("2026-11-24T00:00:00Z", None, {"lo": 50.0, "hi": 100.0}),
            _record("2026-11-25T00:00:00Z", None, {"lo": 40.0, "hi": 101.0})):
    run_file.write_json(throughput_report.result_path(root, r), r)
  by = throughput_report.load(root)
  assert [len(v) for v in by.values()] == [3]
  text = throughput_report.page(by)
  assert "| lo | 40.00 | 25,600 | 819,200 | 10.00 | 250.0 | 62% |" in text  # newest
  assert "| lo | 50.00 | 40.00 | 0.80 | 50% -> 62% | faster |" in text  # vs the one before
  assert "| hi | 100.00 | 101.00 | 1.01 | 25% -> 25% | within noise |" in text
  assert text.count("| 2026-11-2") == 3  # the history, one row per file
  assert "a change is the machine's, not the code's" in text


def test_commits_between_names_only_commits_touching_the_code(tmp_path):
  repo = str(tmp_path / "repo")
  os.makedirs(os.path.join(repo, "halo_jax"))
  os.makedirs(os.path.join(repo, "docs"))

  def git(*args):
    return subprocess.run(["git", "-C", repo, *args], capture_output=True, text=True,
                          check=True, env={**os.environ, "GIT_AUTHOR_NAME": "t",
                                           "GIT_AUTHOR_EMAIL": "t@t", "GIT_COMMITTER_NAME": "t",
                                           "GIT_COMMITTER_EMAIL": "t@t"}).stdout.strip()

  def commit(path, subject):
    with open(os.path.join(repo, path), "a") as f:
      f.write("x\n")
    git("add", path)
    git("commit", "-q", "-m", subject)
    return git("rev-parse", "HEAD")

  try:
    git("init", "-q")
  except (OSError, subprocess.CalledProcessError):
    pytest.skip("git is not available")
  first = commit("halo_jax/a.py", "first")
  commit("docs/b.md", "a docs change")
  commit("halo_jax/a.py", "fuse the sampler kernels")
  last = commit("docs/b.md", "another docs change")
  old = _record("2026-11-24T00:00:00Z", first, {"lo": 50.0})
  new = _record("2026-11-25T00:00:00Z", last, {"lo": 40.0})
  moved = throughput_report.commits_between(old, new, repo)
  assert len(moved) == 1 and moved[0].endswith(" fuse the sampler kernels")
  assert throughput_report.commits_between(old, old, repo) == []
  page = throughput_report.page({("s", "m"): [old, new]}, repo)
  assert "fuse the sampler kernels" in page and "docs change" not in page
