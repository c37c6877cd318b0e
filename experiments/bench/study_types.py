"""What a study is: scenes, variants (a method plus config overrides), a
reference variant and seeds (experiments/bench/studies.py lists them,
ablations.py runs them), and the overrides studies share."""
import dataclasses
from typing import Tuple

from experiments.bench import suites


@dataclasses.dataclass(frozen=True)
class Variant:
  name: str
  method: str
  overrides: Tuple[Tuple[str, object], ...] = ()
  note: str = ""
  # the variant it is judged against, where that is not the default
  # (identity.reference_of): the one it adds to
  against: str = ""


@dataclasses.dataclass(frozen=True)
class Study:
  title: str
  question: str
  scenes: Tuple[suites.Scene, ...]
  variants: Tuple[Variant, ...]
  reference: str            # the variant that is the current default
  seeds: int
  # "steps": each stage stops at MATCHED_STEPS; "time": the CPU suite's
  # training-time budget, each run's front scored on the validation views.
  budget: str = "steps"
  # a "time" study scores each run's front (its state at the suite's front
  # times, rendered on every validation view after training); False: only
  # the end, where fronts would cost more than the runs (fern's 15 views)
  front: bool = True
  # a "time" study's reference seconds (0: the CPU suite's), with a curve
  # point every budget_s / curve_points as in the budget study's suites
  budget_s: float = 0.0


def both(field, value):
  """The same override on Lo and Hi (Hi starts as Lo's exact copy, so model
  fields must agree)."""
  return ((f"lo.{field}", value), (f"hi.{field}", value))


# methods/halo.py took two of these settings: each variant states its own
NEUTRAL_START = both("model.density_bias", -1.0)


def hi_lr(lr):
  return (("hi.lr_init", lr), ("hi.lr_final", lr / 10))


# the suite's baseline beside a study's variants
BASELINE = Variant("nerf_tuned", "nerf_tuned", note="the baseline, as in the suite")
