"""The budget page's candidate section (experiments/bench/candidate_report.py):
a study variant replaces halo only where the study's halo is the suite's own
run, on the same seeds."""
import json
import os

from experiments.bench import candidate_report


def _write(root, scene, variant, seed, psnr, adopted=None):
  path = os.path.join(root, "ablations", "s960", scene, variant, f"seed{seed}.json")
  os.makedirs(os.path.dirname(path), exist_ok=True)
  record = {"seed": seed, "psnr": psnr}
  if adopted:
    record["adopted_from"] = adopted if adopted == "bare" else {"path": adopted}
  with open(path, "w") as f:
    json.dump(record, f)


def test_the_candidate_replaces_halo_only_where_the_study_ran_the_suites_halo(tmp_path):
  root = str(tmp_path)
  runs = {s: {"halo": [{"seed": k, "psnr": 20.0} for k in (0, 1)],
              "nerf_tuned": [{"seed": k, "psnr": 21.0} for k in (0, 1)]}
          for s in ("a", "b", "c", "d", "e")}
  for k in (0, 1):
    _write(root, "a", "halo", k, 20.0, f"budget_960/budget/a/halo/seed{k}.json")
    _write(root, "a", "cand", k, 22.0)
    _write(root, "b", "halo", k, 19.0)          # the study's own halo: another config
    _write(root, "b", "cand", k, 22.0)
    _write(root, "c", "halo", k, 20.0, f"budget_960/budget/c/halo/seed{k}.json")
    _write(root, "d", "halo", k, 20.0, "bare")  # an older record's bare path
    _write(root, "d", "cand", k, 22.0)
    # adopted from the suite, but the suite's run has been rerun since
    _write(root, "e", "halo", k, 19.5, f"budget_960/budget/e/halo/seed{k}.json")
    _write(root, "e", "cand", k, 22.0)
  _write(root, "c", "cand", 0, 22.0)            # one seed of two
  new, done = candidate_report.swapped(runs, root, candidate=("s960", "cand"))
  assert done == ["a"]
  assert [r["psnr"] for r in new["a"]["halo"]] == [22.0, 22.0]
  assert all(new[s] is runs[s] for s in "bcde")
  text = candidate_report.lines(runs, root, lambda r, n: f"goals over {len(r)}", 5,
                                candidate=("s960", "cand"))
  assert "| a (2) | 20.00 | 22.00 | 21.00 | -1.00 | +1.00 |" in text
  assert text[-2] == "With the candidate: goals over 5"
