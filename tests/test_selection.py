"""experiments/bench/selection.py: --only picks runs by name, and says why it picks none."""
import pytest

from experiments.bench import selection

RUNS = [("lego", "halo", 0), ("lego", "halo+unseen", 0), ("fern", "halo", 1)]


def _name(r):
  return f"{r[0]}/{r[1]}/seed{r[2]}"


def test_selects_by_a_search_of_the_name_in_plan_order():
  assert selection.select(RUNS, _name, "", part="method", plan="suite") == RUNS
  assert selection.select(RUNS, _name, "/halo/", part="method", plan="suite") == [RUNS[0], RUNS[2]]
  assert selection.select(RUNS, _name, r"halo\+unseen", part="method", plan="suite") == [RUNS[1]]


def test_an_empty_selection_names_the_flag_the_plan_and_the_escape():
  with pytest.raises(ValueError) as e:
    selection.select(RUNS, _name, "halo+unseen", part="variant", plan="study")
  msg = str(e.value)
  assert msg.startswith("--only='halo+unseen' matches no run of the study")
  assert "scene/variant/seed<k>" in msg and "\\+" in msg


def test_a_bad_pattern_is_refused_before_anything_runs():
  with pytest.raises(ValueError, match=r"--only='\(halo' is not a regular expression"):
    selection.select(RUNS, _name, "(halo", part="method", plan="suite")
