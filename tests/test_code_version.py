"""halo_jax/bench/code_version.py: records pool by the fingerprint their code measures."""
import subprocess

import pytest

from halo_jax.bench import code_version
from halo_jax import provenance


def _git(*args):
  return subprocess.run(["git", "-C", code_version.REPO, *args], capture_output=True, text=True,
                        check=True).stdout.strip()


def _history():
  try:
    head = _git("rev-parse", "HEAD")
    shallow = _git("rev-parse", "--is-shallow-repository") == "true"
  except (OSError, subprocess.CalledProcessError):
    pytest.skip("not a git checkout")
  if shallow:
    pytest.skip("a shallow clone has no history to compare")
  return head


FIGURES = {"default/halo": {"losses": {"lo": [[0, 0.25], [1, 0.125]]}, "psnr": [12.5]},
           "knights/halo": {"losses": {"hi": [[0, 0.5]]}, "psnr": [20.0]},
           "default/nerf_tuned": {"losses": {"hi": [[0, 0.3]]}, "psnr": [11.0]}}


def test_a_fingerprint_moves_with_any_figure_of_its_method_and_no_other():
  fp = code_version.of_runs(FIGURES, "halo")
  assert len(fp) == 12
  moved = {**FIGURES, "knights/halo": {"losses": {"hi": [[0, 0.5000001]]}, "psnr": [20.0]}}
  assert code_version.of_runs(moved, "halo") != fp
  other = {**FIGURES, "default/nerf_tuned": {"losses": {"hi": [[0, 0.31]]}, "psnr": [11.0]}}
  assert code_version.of_runs(other, "halo") == fp
  assert code_version.of_runs(FIGURES, "freenerf") is None


def test_records_pool_by_fingerprint_and_the_rest_is_set_aside(tmp_path):
  head = _history()
  table_path = str(tmp_path / "fingerprints.json")
  code_version.record(head, FIGURES, views=1, path=table_path)
  table = code_version.load(table_path)
  tree = provenance.code_tree(head)
  assert table[tree]["methods"]["halo"] == code_version.of_runs(FIGURES, "halo")

  def rec(method, **git):
    return {"method": method, "psnr": 20.0,
            "provenance": {"git": {"commit": head, "dirty": False, **git}}}
  ok = [rec("halo"), rec("halo", code_tree=tree)]
  modified = rec("halo", dirty=True, code_dirty=True)
  old_modified = rec("halo", dirty=True)          # an old record: no code_dirty field
  docs_only = rec("halo", dirty=True, code_dirty=False)
  unmeasured = rec("halo", code_tree="0" * 12)
  assert code_version.of_record(docs_only, table) == table[tree]["methods"]["halo"]
  assert code_version.of_record(modified, table) == code_version.MODIFIED
  assert code_version.of_record(old_modified, table) == code_version.MODIFIED
  assert code_version.of_record(unmeasured, table) == code_version.UNMEASURED
  assert code_version.of_record(rec("freenerf"), table) == code_version.UNMEASURED
  fp, chosen, aside = code_version.choose(ok + [docs_only, modified, old_modified, unmeasured],
                                          table)
  assert fp == table[tree]["methods"]["halo"]
  assert len(chosen) == 3 and len(aside) == 3
  assert code_version.choose([modified], table) == (None, [], [modified])


def test_a_code_tree_changes_exactly_when_the_training_code_does():
  head = _history()
  touched = _git("log", "-n", "1", "--format=%H", head, "--", "halo_jax").strip()
  untouched = [c for c in _git("log", "-n", "40", "--format=%H", head).split()
               if not _git("diff", "--name-only", f"{c}~1", c, "--",
                           *provenance.TRAINING_CODE)]
  assert provenance.code_tree(touched) != provenance.code_tree(f"{touched}~1")
  if untouched:
    c = untouched[0]
    assert provenance.code_tree(c) == provenance.code_tree(f"{c}~1")
