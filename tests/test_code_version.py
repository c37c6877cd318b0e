"""experiments/bench/code_version.py: records pool by the fingerprint their code measures."""
import subprocess

import pytest

from experiments.bench import code_version
from experiments.bench import git_state


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
  tree = git_state.code_tree(head)
  assert table[tree]["methods"]["halo"] == code_version.of_runs(FIGURES, "halo")

  def rec(method, **git):
    return {"method": method, "psnr": 20.0,
            "provenance": {"git": {"commit": head, "dirty": False, **git}}}
  ok = [rec("halo"), rec("halo", code_tree=tree)]
  modified = rec("halo", dirty=True, code_dirty=True)
  old_modified = rec("halo", dirty=True)          # an old record: no code_dirty field
  docs_only = rec("halo", dirty=True, code_dirty=False)
  unmeasured = rec("halo", code_tree="0" * 12, commit="0" * 40)  # no commit git knows
  # a record's commit measured again, under today's definition of its tree
  remeasured = rec("halo", code_tree="0" * 12)
  assert code_version.of_record(remeasured, table) == table[tree]["methods"]["halo"]
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
  # the last commit that changed a file of the code (not only the data beside it)
  code = [f":(exclude){d}" for d in git_state.DATA_FILES]
  touched = _git("log", "-n", "1", "--format=%H", head, "--", "halo_jax", *code).strip()
  untouched = [c for c in _git("log", "-n", "40", "--format=%H", head).split()
               if not _git("diff", "--name-only", f"{c}~1", c, "--",
                           *git_state.TRAINING_CODE)]
  assert git_state.code_tree(touched) != git_state.code_tree(f"{touched}~1")
  # a commit that changed only the step table keeps its tree (the table's digest sees it)
  data_only = [c for c in _git("log", "-n", "40", "--format=%H", head).split()
               if _git("diff", "--name-only", f"{c}~1", c, "--", *git_state.TRAINING_CODE)
               .split() == list(git_state.DATA_FILES)]
  if data_only:
    assert git_state.code_tree(data_only[0]) == git_state.code_tree(f"{data_only[0]}~1")
  if untouched:
    c = untouched[0]
    assert git_state.code_tree(c) == git_state.code_tree(f"{c}~1")


def test_a_change_to_the_committed_step_table_is_reported(tmp_path):
  """The fingerprint run writes its own table, so the companion digest is what
  sees the committed one: a changed entry changes its method's digest only,
  and the report names that method."""
  import json
  from halo_jax import step_table
  with open(step_table.TABLE) as f:
    table = json.load(f)
  before = code_version.step_table_digests(step_table.TABLE)
  key = min(code_version.suite_step_keys()["nerf_tuned"])
  assert key in table["entries"], key
  table["entries"][key]["step_s"] *= 1.5
  changed = str(tmp_path / "steps.json")
  with open(changed, "w") as f:
    json.dump(table, f)
  after = code_version.step_table_digests(changed)
  assert {m for m in before if before[m] != after[m]} == {"nerf_tuned"}
  fingerprints = {"t": {"definition": code_version.DEFINITION, "commit_time": "1",
                        "methods": {}, "step_table": before}}
  assert code_version.step_table_changes(fingerprints, now=after) == ["nerf_tuned"]
  assert code_version.step_table_changes(fingerprints, now=before) == []


def test_trees_measured_equal_on_one_machine_are_one_code_across_machines():
  """Old code measured on machine A and again on machine B, beside new code
  measured on B: the last bits follow the machine, so the new code is the
  old one's where B measured them equal, and keeps the old one's name."""
  table = {
      "old": {"commit_time": "1", "machine": "A", "methods": {"halo": "a1", "nerf_tuned": "n1"},
              "machines": {"B": {"methods": {"halo": "b1", "nerf_tuned": "m1"}}}},
      "new": {"commit_time": "2", "machine": "B", "methods": {"halo": "b1", "nerf_tuned": "m2"}},
  }
  assert code_version.classes("halo", table) == {"old": "a1", "new": "a1"}
  assert code_version.classes("nerf_tuned", table) == {"old": "n1", "new": "m2"}
  assert code_version.current("halo", table) == "a1"
  rec = lambda tree: {"method": "halo", "provenance": {"git": {"code_tree": tree}}}  # noqa: E731
  assert code_version.of_record(rec("old"), table) == code_version.of_record(rec("new"), table)
  assert code_version.of_record(rec("other"), table) == code_version.UNMEASURED


def test_a_change_to_one_kinds_recipe_leaves_the_other_kinds_current():
  """Fingerprints are measured per scene kind: a new tree that moves llff's
  numbers alone keeps blender's records current under their old name, and
  names llff's class by its own fingerprint."""
  figures = {"lego_8view/halo": {"psnr": [20.0]}, "fern_4view/halo": {"psnr": [18.0]}}
  changed = dict(figures, **{"fern_4view/halo": {"psnr": [19.0]}})
  kinds = lambda f: {"halo": code_version.kinds_of_runs(f, "halo")}  # noqa: E731
  table = {
      "old": {"commit_time": "1", "machine": "B", "kinds": kinds(figures),
              "methods": {"halo": code_version.of_runs(figures, "halo")}},
      "new": {"commit_time": "2", "machine": "B", "kinds": kinds(changed),
              "methods": {"halo": code_version.of_runs(changed, "halo")}},
  }
  assert set(kinds(figures)["halo"]) == {"blender", "llff"}
  old_name, new_name = table["old"]["methods"]["halo"], table["new"]["methods"]["halo"]
  assert code_version.current("halo", table, "blender") == old_name
  assert code_version.current("halo", table, "llff") == new_name
  rec = lambda tree, config: {"method": "halo", "config": config,  # noqa: E731
                              "provenance": {"git": {"code_tree": tree}}}
  assert code_version.of_record(rec("old", "configs/blender.py:lego_8view_cpu"), table) == old_name
  assert code_version.of_record(rec("old", "configs/llff.py:fern_4view_cpu"), table) == old_name
  assert code_version.of_record(rec("new", "configs/llff.py:fern_4view_cpu"), table) == new_name


def test_the_step_table_is_data_not_code(tmp_path):
  """A commit that changes only the committed step table keeps its code tree
  (HEAD stays measured when new keys are measured); the earlier definition,
  which records without a stored tree were keyed by, hashed it in."""
  repo = str(tmp_path)
  git = lambda *a: subprocess.run(["git", "-C", repo, *a], check=True, capture_output=True,
                                  text=True).stdout.strip()
  git("init", "-q")
  git("config", "user.email", "t@t"), git("config", "user.name", "t")
  (tmp_path / "halo_jax").mkdir()
  (tmp_path / "halo_jax" / "step_table.json").write_text("{}")
  (tmp_path / "halo_jax" / "loop.py").write_text("x = 1\n")
  git("add", "-A"), git("commit", "-qm", "a")
  first = git("rev-parse", "HEAD")
  (tmp_path / "halo_jax" / "step_table.json").write_text('{"entries": {}}')
  assert not git_state.git_state(repo)["code_dirty"]  # a table edit leaves the code clean
  git("commit", "-qam", "b")
  table_only = git("rev-parse", "HEAD")
  (tmp_path / "halo_jax" / "loop.py").write_text("x = 2\n")
  assert git_state.git_state(repo)["code_dirty"]
  git("commit", "-qam", "c")
  code = git("rev-parse", "HEAD")
  tree = lambda c, **k: git_state.code_tree(c, repo, **k)
  assert tree(first) == tree(table_only) != tree(code)
  assert tree(first, with_data=True) != tree(table_only, with_data=True)
