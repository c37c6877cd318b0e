"""CI records (results/ci): parsed from what `.ci/run` printed, the newest
chosen by date, and a file that is not one refused with its name."""
import pytest

from experiments.bench import ci_records

TEXT = """CI (.ci/run) on a fresh clone of abc1234, 2 CPU cores (AMD EPYC family 26), 2026-11-30, without the datasets:
650 passed, 16 skipped, 1 failed, 2 warnings in 545.50s (0:09:05)
real	10m2.250s
"""


def test_a_record_parses_into_its_figures():
  r = ci_records.parse(TEXT, "x.txt")
  assert (r.commit, r.date, r.conditions) == ("abc1234", "2026-11-30", "without the datasets")
  assert r.machine == "2 CPU cores (AMD EPYC family 26)"
  assert r.counts == {"passed": 650, "skipped": 16, "failed": 1}
  assert (r.tests_s, r.total_s) == (545.5, 602.25)
  line = ci_records.readme_sentence(r)
  assert "10 min 2 s" in line and "9 min 6 s in the tests" in line
  assert "650 passed, 16 skipped, 1 failed" in line


def test_the_newest_record_is_the_latest_date(tmp_path):
  (tmp_path / "abc1234.txt").write_text(TEXT)
  (tmp_path / "def5678.txt").write_text(TEXT.replace("abc1234", "def5678")
                                        .replace("2026-11-30", "2026-11-29"))
  assert ci_records.newest(str(tmp_path)).commit == "abc1234"
  assert ci_records.newest(str(tmp_path / "none")) is None


@pytest.mark.parametrize("broken", ["", TEXT.replace("real", "user"),
                                    TEXT.replace(" in 545.50s", "")])
def test_a_file_that_is_not_a_record_is_named(tmp_path, broken):
  with pytest.raises(ValueError, match="bad.txt: not a CI record"):
    ci_records.parse(broken, "bad.txt")


def test_a_duration_rounds_to_whole_seconds_before_minutes():
  assert ci_records.minutes(1439.6) == "24 min 0 s"
  assert ci_records.minutes(1366.4) == "22 min 46 s"
  assert ci_records.minutes(59.5) == "1 min 0 s"


def test_a_record_that_names_its_failed_tests_still_parses():
  """ci_record.py keeps pytest's FAILED lines before the summary."""
  lines = TEXT.splitlines()
  named = "\n".join([lines[0], "FAILED tests/test_x.py::test_y - AssertionError: 1 == 2",
                     *lines[1:]]) + "\n"
  r = ci_records.parse(named, "x.txt")
  assert r.counts == {"passed": 650, "skipped": 16, "failed": 1} and r.tests_s == 545.5


def test_a_record_keeps_which_tests_failed_and_why():
  from experiments import ci_record  # pylint: disable=import-outside-toplevel
  out = ["tests/test_a.py F.", "    def test_x():", ">       assert n >= 25, n",
         "E       AssertionError: 24", "E       assert 24 >= 25",
         "FAILED tests/test_a.py::test_x - AssertionError: 24",
         "1 failed, 1 passed in 3.00s"]
  kept = ci_record.kept_lines(out)
  assert kept == ["FAILED tests/test_a.py::test_x - AssertionError: 24",
                  "E       AssertionError: 24", "E       assert 24 >= 25"]
  # the record still parses: its summary is pytest's last line, after them
  text = "\n".join(["CI (.ci/run) on a fresh clone of abc1234, 2 CPU cores (X family 1), "
                    "2026-11-30, idle:"] + kept + out[-1:] + ["real\t0m4.000s"]) + "\n"
  assert ci_records.parse(text, "x.txt").counts == {"failed": 1, "passed": 1}
  assert ci_record.kept_lines(["2 passed in 1.00s"]) == []
