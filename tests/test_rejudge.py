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
