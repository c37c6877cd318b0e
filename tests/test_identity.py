"""identity.py: fingerprint runs show a variant identical to its reference at
a budget where its switch is never reached, and different where it is."""
import pytest

from experiments.bench import ablations, fingerprint, identity, suites
from experiments.bench.study_types import Study, Variant


@pytest.mark.slow
def test_a_switch_past_the_budget_is_identical_and_one_within_it_is_not(tmp_path):
  lattice = tuple(s for s in suites.VALIDATION_SCENES if s.name == "lattice")
  study = Study("t", "q", lattice, (
      Variant("halo", "halo"),
      Variant("dense_never", "halo", (("hi.sampler.dense_eval_after", 10 ** 6),)),
      Variant("dense_at_once", "halo", (("hi.sampler.dense_eval_after", 1),))),
      "halo", 2, budget="time", front=False, budget_s=60.0)
  figs = {f"{s.name}/{v.name}": fingerprint.run(
      s, v.method, str(tmp_path / v.name), 1, ablations.terms(study),
      ablations.run_overrides(study, v)) for s, v in identity.runs(study)}
  assert identity.verdicts(study, figs) == {"dense_never": {"lattice": True},
                                            "dense_at_once": {"lattice": False}}
  # the switch is crossed only where it is set within the steps Hi trains
  assert figs["lattice/dense_at_once"]["psnr"] != figs["lattice/halo"]["psnr"]
  path = identity.write("t", 60.0, identity.verdicts(study, figs), str(tmp_path / "identity"))
  assert identity.read("t", str(tmp_path / "identity"))["dense_never"] == {"lattice": True}
  assert path.endswith("t.json")
