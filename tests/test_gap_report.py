"""experiments/bench/gap_report.py: what a `<parent>+<change>` variant
recovers of its parent's gap, on made-up records (numbers checked by hand)."""
from experiments.bench import gap_report
from experiments.bench.study_types import Study, Variant


def _study():
  return Study(title="t", question="q", scenes=(), reference="ours", seeds=2,
               variants=(Variant("ours", "halo"), Variant("theirs", "halo_authors"),
                         Variant("theirs+start", "halo_authors", (("lo.fg_steps", 1),)),
                         Variant("theirs+other", "halo_authors", (("lo.fg_steps", 2),))))


def _recs(psnr):
  return {(scene, variant): [{"seed": seed, "psnr": p} for seed, p in seeds.items()]
          for (scene, variant), seeds in psnr.items()}


def test_the_gap_each_change_recovers():
  recs = _recs({("a", "ours"): {0: 20.0, 1: 22.0}, ("a", "theirs"): {0: 16.0, 1: 18.0},
                ("a", "theirs+start"): {0: 19.0, 1: 20.0},
                ("b", "ours"): {0: 30.0}, ("b", "theirs"): {0: 20.0},
                ("b", "theirs+start"): {0: 26.0}})
  rows = {l.split(" | ")[0]: l for l in gap_report.lines(_study(), recs) if l.startswith("| `")}
  # pairs (a,0), (a,1), (b,0): parent gaps -4, -4, -10 -> -6; child gaps -1, -2, -4 -> -2.33;
  # recovered 3, 2, 6 -> +3.67
  assert rows["| `theirs+start`"] == "| `theirs+start` | 3 | -6.00 | -2.33 | +3.67 |"
  assert rows["| `theirs+other`"] == "| `theirs+other` | 0 | | | |"
  assert "| `theirs`" not in rows   # no parent among the variants


def test_no_section_without_a_parent_variant():
  study = Study(title="t", question="q", scenes=(), reference="ours", seeds=2,
                variants=(Variant("ours", "halo"), Variant("other", "halo")))
  assert gap_report.lines(study, {}) == []
