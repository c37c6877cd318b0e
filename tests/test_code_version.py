"""experiments/code_version.py: the code version a result file names."""
import subprocess

import pytest

from experiments import code_version


def _git(*args):
  return subprocess.run(["git", "-C", code_version.REPO, *args], capture_output=True, text=True,
                        check=True).stdout.strip()


def _record(commit, dirty=False):
  return {"provenance": {"git": {"commit": commit, "dirty": dirty}}}


def test_unknown_commits_name_themselves_and_versions_are_listed_once():
  fake = "0123456789abcdef0123456789abcdef01234567"
  recs = [_record(fake), _record(fake), _record(fake, dirty=True), _record(None)]
  assert code_version.of_records(recs) == "0123456, 0123456+, ?"


def test_a_commit_maps_to_the_newest_code_change_at_or_before_it():
  try:
    head = _git("rev-parse", "HEAD")
    shallow = _git("rev-parse", "--is-shallow-repository") == "true"
  except (OSError, subprocess.CalledProcessError):
    pytest.skip("not a git checkout")
  if shallow:
    pytest.skip("a shallow clone may not hold the commit that changed the code")
  version = code_version.of_commit(head)
  full = _git("rev-parse", version)
  # an ancestor of (or equal to) HEAD, and one that touched the training code
  assert subprocess.run(["git", "-C", code_version.REPO, "merge-base", "--is-ancestor", full,
                         head]).returncode == 0
  assert _git("diff", "--name-only", f"{full}~1", full, "--", *code_version.TRAINING_CODE)
  # and every commit after it that touched the training code is a neutral one
  later = _git("log", "--format=%H", f"{full}..{head}", "--", *code_version.TRAINING_CODE)
  assert all(c in code_version.NEUTRAL for c in later.split())


def test_neutral_commits_do_not_start_a_version(monkeypatch):
  try:
    head = _git("rev-parse", "HEAD")
    if _git("rev-parse", "--is-shallow-repository") == "true":
      pytest.skip("a shallow clone may not hold the commits that changed the code")
  except (OSError, subprocess.CalledProcessError):
    pytest.skip("not a git checkout")
  version = _git("rev-parse", code_version.of_commit(head))
  code_version.of_commit.cache_clear()
  monkeypatch.setattr(code_version, "NEUTRAL", {**code_version.NEUTRAL, version: "test"})
  before = code_version.of_commit(head)
  code_version.of_commit.cache_clear()
  assert before != version[:7]
  # the version before it: the newest code change before it that is not neutral
  earlier = _git("log", "--format=%H", f"{version}~1", "--", *code_version.TRAINING_CODE)
  assert before == next(c for c in earlier.split() if c not in code_version.NEUTRAL)[:7]

