"""Benchmark suites as data: which scenes, methods and seeds, and each run's budget.

A suite is run by experiments/benchmark.py and reported by experiments/report.py.
Scene configs are '<file>:<variant>' strings, as --config takes them; `needs`
is the data folder (under $HALO_DATA) a scene reads, so a machine without it
skips the scene instead of failing.
"""
import dataclasses
from typing import Tuple

from halo_jax import methods

# The registry's compared and reported methods (methods.with_role)
ALL_METHODS = methods.with_role(methods.base.COMPARED, methods.base.REPORTED)
# halo+unseen is halo itself where every point a test view sees lies in a
# training frustum (forward-facing scenes): no run of its own there.
FORWARD_FACING_METHODS = tuple(m for m in ALL_METHODS if m != "halo+unseen")
# FreeNeRF's mask schedules ordered P.E. bands; the light-field field has
# none, and nerf_paper's coarse+fine sampler is for 3D rays.
LIGHT_FIELD_METHODS = ("nerf_tuned", "halo")


@dataclasses.dataclass(frozen=True)
class Scene:
  name: str                  # result folder
  config: str                # 'configs/<file>.py:<variant>' (CPU-sized)
  seeds: int
  needs: str = ""            # data folder under $HALO_DATA ('' for built-in scenes)
  methods: Tuple[str, ...] = ALL_METHODS
  # (dotted field, value) applied after the method and the suite's overrides:
  # a variant of the scene's config (the ingredient study's single changes)
  overrides: Tuple[Tuple[str, object], ...] = ()
  # A split of the scene that is not its test split ('' for none): after
  # training, each stage that renders is scored on all of its views, so that
  # a stage can be compared with the one before it without the test views.
  validation: str = ""


@dataclasses.dataclass(frozen=True)
class Suite:
  scenes: Tuple[Scene, ...]
  budget_s: float            # training seconds per method and run (mode 'time')
  steps: int                 # training steps per method and run (mode 'steps')
  cores: int = 0             # CPU cores the runs are pinned to (0: all)
  curve_points: int = 6      # held-out evaluations during training, for the curves
  description: str = ""
  overrides: Tuple[Tuple[str, object], ...] = ()  # (dotted field, value) for every run
  # Training seconds at which each run's state is saved and, after training,
  # scored on every held-out view: the error-against-time front (the final
  # state is its last point).
  front_s: Tuple[float, ...] = ()


CPU = Suite(
    description=(
        "Every method on every scene we have, on one CPU core (so that a second job "
        "can share the machine without disturbing the timings), 240 s of training "
        "per method and run, three seeds."),
    cores=1, budget_s=240.0, steps=1500, curve_points=4, front_s=(15.0, 30.0, 60.0, 120.0),
    # held-out curves on 2 views: a NeRF with 64 + 128 samples renders ~1k rays/s
    # on one core, and the curves are for the plots, not the tables
    overrides=(("eval.curve_views", 2),),
    scenes=(
        Scene("lego_8view", "configs/blender.py:lego_8view_cpu", 3, "nerf_synthetic/lego"),
        Scene("dnerf_lego", "configs/dnerf.py:lego_cpu", 3, "dnerf/lego", validation="val"),
        Scene("dnerf_hook", "configs/dnerf.py:hook_cpu", 3, "dnerf/hook", validation="val"),
        Scene("dnerf_jumpingjacks", "configs/dnerf.py:jumpingjacks_cpu", 3,
              "dnerf/jumpingjacks", validation="val"),
        Scene("lattice", "configs/procedural.py:lattice_8view_cpu", 3),
        Scene("spheres", "configs/procedural.py:spheres_8view_cpu", 3),
        Scene("lego_oneside", "configs/blender.py:lego_oneside_cpu", 3, "nerf_synthetic/lego"),
        Scene("fern_4view", "configs/llff.py:fern_4view_cpu", 3, "nerf_llff_data/fern",
              FORWARD_FACING_METHODS),
        Scene("knights", "configs/stanford_lf.py:knights_cpu", 3, "stanford_lf/knights",
              LIGHT_FIELD_METHODS),
    ))

# Views that are neither training nor test views of any protocol: lego's
# training views that neither the 8-view nor the one-side list uses.
LEGO_VALIDATION_VIEWS = "r_0,r_11,r_18,r_22,r_29,r_33,r_44,r_47,r_66,r_77,r_88,r_99"
_LEGO_VALIDATION = (("data.test_split", "train"), ("data.test_views", LEGO_VALIDATION_VIEWS))

# Stress scenes (docs/validation.md): built-in scenes where a setting chosen on
# spheres and lattice can fail: a thin object on white, a mostly empty volume.
STRESS = (
    Scene("thin", "configs/procedural.py:thin_8view_cpu", 2, validation="val"),
    Scene("sparse", "configs/procedural.py:sparse_8view_cpu", 2, validation="val"),
)

# fern's images outside the 4-view split (train 005 013 015 016, test 014)
FERN_VALIDATION_VIEWS = "000,001,002,003,004,006,007,008,009,010,011,012,017,018,019"
# knights' grid views between the training corners, off the test views
KNIGHTS_VALIDATION_VIEWS = "06_06,06_10,10_06,10_10,08_08,05_08,11_08,08_04"

# The 360-degree scenes with views for choosing settings (docs/validation.md):
# the built-in scenes' val cameras, lego's unused training views.
VALIDATION_360 = (
    Scene("spheres", "configs/procedural.py:spheres_8view_cpu", 2, validation="val"),
    Scene("lattice", "configs/procedural.py:lattice_8view_cpu", 2, validation="val"),
    *STRESS,
    Scene("lego_8view", "configs/blender.py:lego_8view_cpu", 2, "nerf_synthetic/lego",
          overrides=_LEGO_VALIDATION),
    Scene("lego_oneside", "configs/blender.py:lego_oneside_cpu", 2, "nerf_synthetic/lego",
          overrides=_LEGO_VALIDATION),
)

# The overrides that put a validation scene's views in the test slot (each
# scene's own overrides then replace them where its views are not a split of
# its own).
VALIDATION_VIEWS = (("data.test_split", "val"), ("data.test_views", "all"))

# Every scene kind with views that are neither training nor test views: where
# a default is chosen (docs/validation.md). The suite's overrides put each
# scene's validation views in the test slot; scenes override them where
# their views are not a split of their own.
VALIDATION_SCENES = VALIDATION_360 + (
    Scene("dnerf_lego", "configs/dnerf.py:lego_cpu", 2, "dnerf/lego"),
    Scene("dnerf_hook", "configs/dnerf.py:hook_cpu", 2, "dnerf/hook"),
    Scene("dnerf_jumpingjacks", "configs/dnerf.py:jumpingjacks_cpu", 2, "dnerf/jumpingjacks"),
    Scene("dnerf_hellwarrior", "configs/dnerf.py:hellwarrior_cpu", 2, "dnerf/hellwarrior"),
    Scene("fern_4view", "configs/llff.py:fern_4view_cpu", 2, "nerf_llff_data/fern",
          FORWARD_FACING_METHODS, overrides=(("data.test_views", FERN_VALIDATION_VIEWS),)),
    Scene("knights", "configs/stanford_lf.py:knights_cpu", 2, "stanford_lf/knights",
          LIGHT_FIELD_METHODS, overrides=(("data.test_views", KNIGHTS_VALIDATION_VIEWS),)),
)

# HALO against nerf_tuned on every validation scene, on the CPU suite's terms
# (the same budget, core and step table), each scene's validation views in the
# test slot: the comparison the test views' headline is checked against
# without reading them. No fronts: the saved states are for the CPU suite's
# error-against-time figure.
VALIDATION = dataclasses.replace(
    CPU,
    description=(
        "halo against nerf_tuned on every validation scene (docs/validation.md), on the CPU "
        "suite's terms, scored on views that are neither training nor test views."),
    overrides=CPU.overrides + VALIDATION_VIEWS, front_s=(),
    scenes=tuple(dataclasses.replace(s, methods=("nerf_tuned", "halo"))
                 for s in VALIDATION_SCENES))

# Whether HALO's lead holds with a longer budget (docs/budgets.md): the
# validation suite's terms and scenes of every kind (one 360-degree scene,
# one D-NeRF scene, fern, knights) at a quarter and four times its 240
# reference seconds; the 240-s point is the validation suite's own runs.
# The held-out curve has a point every 120 reference seconds at 960.
BUDGET_SCENES = ("lego_8view", "dnerf_lego", "fern_4view", "knights")


# Seeds on dynamic scenes at 960 s: their margins vary more from seed to seed.
DYNAMIC_SEEDS_960 = 3


def _budget_suite(budget_s: float, curve_points: int, scenes=BUDGET_SCENES,
                  dynamic_seeds: int = 0) -> Suite:
  chosen = tuple(s for s in VALIDATION.scenes if s.name in scenes)
  if dynamic_seeds:
    chosen = tuple(dataclasses.replace(s, seeds=dynamic_seeds)
                   if s.config.startswith("configs/dnerf.py") else s for s in chosen)
  names = "every validation scene" if len(chosen) == len(VALIDATION.scenes) else ", ".join(
      s.name for s in chosen)
  return dataclasses.replace(
      VALIDATION, budget_s=budget_s, curve_points=curve_points,
      description=(f"The validation suite at {budget_s:g} reference seconds on "
                   f"{names}: the budget study (docs/budgets.md)."),
      scenes=chosen)


BUDGET_60 = _budget_suite(60.0, 4)
# Every validation scene: whether the lead holds with four times the budget
# is a claim about every kind, not the four scenes of the 60-s point.
BUDGET_960 = _budget_suite(960.0, 8, tuple(s.name for s in VALIDATION.scenes),
                           DYNAMIC_SEEDS_960)
# suite name -> reference seconds: the budget study's three points
BUDGET_STUDY = {"budget_60": 60.0, "validation": 240.0, "budget_960": 960.0}

# A few seconds per run: the benchmark's own test and a quick look at the machinery.
SMOKE = Suite(
    description="Two methods on the built-in scene for a few seconds (tests).",
    budget_s=4.0, steps=6, curve_points=2, front_s=(1.0, 2.0),
    overrides=(("data.procedural_size", 32), ("data.test_views", "r_0,r_100"),
               ("eval.curve_views", 1), ("lo.model.width", 32), ("hi.model.width", 32),
               ("ray.model.width", 32), ("lo.batch_rays", 128), ("hi.batch_rays", 128),
               ("ray.batch_rays", 128), ("ray.bank_rays", 1024), ("hi.empty.bank_rays", 1024),
               ("lo.sampler.num_samples", 8), ("hi.sampler.num_samples", 8),
               ("baseline.num_samples", 8),
               # its seconds are thousands of tiny steps, past a sampler switch
               # whose steps the step table has no entry for
               ("hi.sampler.switch_step", 0)),
    scenes=(Scene("spheres", "configs/procedural.py:spheres_8view_cpu", 1,
                  methods=("nerf_tuned", "halo"), validation="val"),))

# The frequency rule's choice against the hand-set CPU config: halo_auto here,
# halo from the CPU suite (the same budget, cores and overrides).
AUTO = dataclasses.replace(
    CPU,
    description=(
        "HALO with Lo-NeRF's frequency chosen by the frequency rule (halo_auto), on the CPU "
        "suite's terms; compared with the CPU suite's hand-set halo runs."),
    scenes=(Scene("lego_8view", "configs/blender.py:lego_8view_cpu", 2, "nerf_synthetic/lego",
                  ("halo_auto",)),))


# Which of nerf_tuned's departures from the original NeRF keeps it from the
# few-shot failure: nerf_paper on lego 8 views with one of them at a time
# (and nerf_tuned with the original's ReLU density), at equal steps. Under
# the CPU suite's 240 s nerf_paper trains ~130 steps, far too few to tell a
# collapse from slow training, so this suite is for --mode=steps.
_LEGO = "configs/blender.py:lego_8view_cpu"
INGREDIENT_VARIANTS = (
    ("nerf_paper", "nerf_paper", ()),
    ("nerf_paper+softplus", "nerf_paper",
     (("hi.model.density_activation", "softplus"), ("hi.model.density_bias", -1.0))),
    ("nerf_paper+noise", "nerf_paper", (("hi.density_noise", 1.0),)),
    ("nerf_paper+all_images", "nerf_paper", (("hi.one_image", False),)),
    ("nerf_paper+tuned_lr", "nerf_paper",
     (("hi.lr_init", 2e-3), ("hi.lr_final", 2e-4), ("hi.lr_decay_steps", 0))),
    ("nerf_paper+one_mlp", "nerf_paper",
     (("hi.sampler.kind", "stratified"), ("hi.sampler.num_samples", 64),
      ("hi.sampler.coarse_model", False))),
    ("nerf_tuned+relu", "nerf_tuned",
     (("hi.model.density_activation", "relu"), ("hi.model.density_bias", 0.0))),
)
INGREDIENTS = dataclasses.replace(
    CPU,
    description=(
        "nerf_paper on lego 8 views with one of nerf_tuned's ingredients at a time, and "
        "nerf_tuned with ReLU density; CPU suite terms, run with --mode=steps."),
    scenes=tuple(Scene(name, _LEGO, 1, "nerf_synthetic/lego", (method,), changes)
                 for name, method, changes in INGREDIENT_VARIANTS))

SUITES = {"cpu": CPU, "validation": VALIDATION, "smoke": SMOKE, "auto": AUTO,
          "ingredients": INGREDIENTS, "budget_60": BUDGET_60, "budget_960": BUDGET_960}
