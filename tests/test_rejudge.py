"""experiments/rejudge.py: today's collapse rule over committed records."""
import pytest

from experiments import rejudge


def _record(commit, psnr=20.0):
  return {"stages": {"lo": {"psnr": 15.0}, "ray": {}, "hi": {"psnr": psnr}},
          "learned": {"lo": "learned", "ray": "unchecked", "hi": "learned"},
          "resolved_config": {"data": {"kind": "procedural"},
                              "lo": {"collapse": {"margin_db": 1.0}},
                              "hi": {"collapse": {"margin_db": 1.0}}},
          "provenance": {"git": {"commit": commit}}}


def test_an_older_rules_training_verdict_is_set_aside_and_the_heldout_one_recomputed(
    monkeypatch):
  monkeypatch.setattr(rejudge, "constant_of", lambda record: 15.5)
  monkeypatch.setattr(rejudge, "older_than_rule", lambda commit: commit == "old")
  old = _record("old")
  new = rejudge.rejudge(old)
  # Lo at 15.0 is under the constant 15.5 + 1 dB: no better than a constant image
  assert new["heldout_learned"] == {"lo": "collapsed", "hi": "learned"}
  assert new["learned"] == {"lo": "unjudged", "ray": "unjudged", "hi": "unjudged"}
  assert new["learned_older_rule"] == {"commit": "old", "verdicts": old["learned"]}
  assert old["learned"]["hi"] == "learned"   # the input is not changed
  today = rejudge.rejudge(_record("new"))
  assert today["learned"] == _record("new")["learned"] and "learned_older_rule" not in today
  # a second pass changes nothing
  assert rejudge.rejudge(new) == new


def test_the_rules_commit_is_an_ancestor_of_head():
  if rejudge.older_than_rule("6c5fe1a") is None:
    pytest.skip("no git history here (a shallow clone or an installed copy)")
  assert rejudge.older_than_rule("6c5fe1a") is True
  assert rejudge.older_than_rule(rejudge.RULE_COMMIT) is False
  assert rejudge.older_than_rule("") is None


def test_every_layout_is_rejudged_whatever_the_files_name(monkeypatch, tmp_path):
  import json  # pylint: disable=import-outside-toplevel
  from absl import flags  # pylint: disable=import-outside-toplevel
  monkeypatch.setattr(rejudge, "constant_of", lambda record: 15.5)
  monkeypatch.setattr(rejudge, "older_than_rule", lambda commit: commit == "old")
  no_config = {k: v for k, v in _record("old").items() if k != "resolved_config"}
  gpu = {"scene": "fern", "methods": {"halo": _record("old"), "nerf_tuned": _record("new")}}
  (tmp_path / "study").mkdir()
  (tmp_path / "study" / "seed0.json").write_text(json.dumps(no_config))
  (tmp_path / "h200_seed0.json").write_text(json.dumps(gpu))
  (tmp_path / "fingerprints.json").write_text(json.dumps({"tree": {"methods": {}}}))
  was_parsed = flags.FLAGS.is_parsed()
  flags.FLAGS(["rejudge", f"--results={tmp_path}"], known_only=True)
  try:
    rejudge.main([])
  finally:
    flags.FLAGS["results"].value = flags.FLAGS["results"].default
    if not was_parsed:
      flags.FLAGS.unparse_flags()
  study = json.loads((tmp_path / "study" / "seed0.json").read_text())
  assert study["learned"]["ray"] == "unjudged" and "heldout_learned" not in study
  got = json.loads((tmp_path / "h200_seed0.json").read_text())
  assert got["methods"]["halo"]["learned_older_rule"]["verdicts"]["ray"] == "unchecked"
  assert got["methods"]["halo"]["heldout_learned"] == {"lo": "collapsed", "hi": "learned"}
  assert got["methods"]["nerf_tuned"]["learned"]["ray"] == "unchecked"   # today's rule's run
  assert got["scene"] == "fern" and json.loads((tmp_path / "fingerprints.json").read_text())
