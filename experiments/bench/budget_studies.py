"""The studies that decide HALO's defaults at each budget of the budget
study (suites.BUDGET_STUDY: 60, 240 and 960 reference seconds): a default
changes only where it is not worse by more than 0.3 dB on any scene of its
kind at any of them, and better on the mean (docs/validation.md)."""
from halo_jax import protocol
from experiments.bench import suites
from experiments.bench.study_types import BASELINE, Study, Variant, hi_lr as _hi_lr


# The scenes whose Hi-NeRF the ray field's window samples: every 360-degree
# and forward-facing scene with validation views.
_DEPTH_GUIDED = suites.VALIDATION_360 + tuple(s for s in suites.VALIDATION_SCENES
                                              if s.name == "fern_4view")


def _window(r=0.3, full=0, kind="depth_guided", samples=32, coarse=64):
  """Hi's sampler as the variant names it, with no switch (a variant that
  switches says so, after this)."""
  return (("hi.sampler.kind", kind), ("hi.sampler.num_samples", samples),
          ("hi.sampler.num_coarse", coarse), ("hi.sampler.window", r),
          ("hi.sampler.num_full", full), ("hi.sampler.switch_step", 0))


# Hi-NeRF's window narrowing from the whole ray, and NeRF's fine pass inside
# it. Neither sets num_full: each keeps its scene kind's full-range samples
# (none on 360-degree scenes, 8 of 32 on forward-facing ones, where `full_8`
# is that default).
_NARROWING = (("hi.sampler.window_start", 1.0), ("hi.sampler.window_steps", 100))
_FINE = (("hi.sampler.kind", "depth_guided_fine"), ("hi.sampler.num_coarse", 32),
         ("hi.sampler.num_samples", 32))


# Held-out renders of a Hi that trained this long, densely over the whole ray
# (sampler.dense_eval_after): past Hi's steps at 240 s on every scene the
# window samples (fern_4view's 989 the most), short of them at 960 s (3468 the
# least), so the variant is identical at 60 and 240 s (results/identity/).
DENSE_EVAL_AFTER = 2000
_DENSE_EVAL = (("hi.sampler.dense_eval_after", DENSE_EVAL_AFTER),
               ("hi.sampler.dense_eval_samples", 64))
# The same chance for the baseline: its own stratified sampler, twice its samples.
_BASELINE_DENSE_EVAL = (("hi.sampler.dense_eval_after", DENSE_EVAL_AFTER),
                        ("hi.sampler.dense_eval_samples", 128), ("hi.sampler.switch_step", 0))


# Hi's samples in the window doubled once it has trained this long
# (sampler.switch_step): at the same step as DENSE_EVAL_AFTER, and for the same
# reason, identical at 60 and 240 s; its steps past the switch cost their own
# step-table entry, so at 960 s it trains fewer steps than `halo`.
SAMPLES_SWITCH = DENSE_EVAL_AFTER
_SWITCH_64 = (("hi.sampler.switch_step", SAMPLES_SWITCH), ("hi.sampler.switch_samples", 64))
_BASELINE_SWITCH_128 = (("hi.sampler.switch_step", SAMPLES_SWITCH),
                        ("hi.sampler.switch_samples", 128))
# as they were measured: held-out views rendered with the switched sampler
_NO_DENSE_EVAL = (("hi.sampler.dense_eval_after", 0),)
_SAMPLES_64 = _SWITCH_64 + _NO_DENSE_EVAL
_BASELINE_SAMPLES_128 = _BASELINE_SWITCH_128 + _NO_DENSE_EVAL
# Past the switch, held-out renders with the samples the baseline's twin trains
# and renders with (128 stratified over the whole ray); and the twin given the
# same: twice the samples it trains with.
_SWITCHED_DENSE_EVAL = _SWITCH_64 + (("hi.sampler.dense_eval_after", SAMPLES_SWITCH),
                                      ("hi.sampler.dense_eval_samples", 128))
_BASELINE_SWITCHED_DENSE_EVAL = _BASELINE_SWITCH_128 + (
    ("hi.sampler.dense_eval_after", SAMPLES_SWITCH), ("hi.sampler.dense_eval_samples", 256))
# the baseline given the same chance as HALO's switch (equal_chance.py), and the
# baseline without it: the study's `halo` has no switch either (_window)
BASELINE_TWIN = f"nerf_tuned_samples_128_after_{SAMPLES_SWITCH}"
BASELINE_UNSWITCHED = Variant(BASELINE.name, BASELINE.method, (("hi.sampler.switch_step", 0),),
                              "the baseline without a sampler switch")


def _hi_window_study(budget_s: float) -> Study:
  """Hi-NeRF's samples in and beside the ray field's window, at one budget of
  the budget study (docs/results/budget_study.md)."""
  return Study(
      title=f"Hi-NeRF's samples and the ray field's window, {budget_s:g} reference seconds",
      question=("Whether Hi-NeRF keeps HALO's lead as training grows with its 32 samples "
                "in a narrower window (denser where the surface is), or with some of them "
                "over the whole ray (a surface the window misses can still form), at equal "
                "cost; with a window that narrows from the whole ray; or with a fine pass "
                "of 32 more samples drawn from the window's weights, at equal reference "
                "time; or trained as it is and, once it has trained long, scored with its "
                "held-out views rendered densely (and the baseline given the same); or with "
                "twice its samples in the window once it has trained long; on "
                "every scene whose Hi the window samples. `narrowing` and "
                "`fine_32+32` keep the scene kind's full-range samples, so on fern_4view "
                "they compare with `full_8` (its default)."),
      scenes=_DEPTH_GUIDED,
      variants=(
          Variant("halo", "halo", _window(), "32 samples in r = 0.3 (the CPU config)"),
          Variant("window_0.15", "halo", _window(r=0.15), "32 samples in r = 0.15"),
          Variant("full_8", "halo", _window(full=8),
                  "23 samples in r = 0.3 and 8 over the whole ray"),
          Variant("window_0.15+full_8", "halo", _window(r=0.15, full=8),
                  "23 samples in r = 0.15 and 8 over the whole ray"),
          Variant("narrowing", "halo", _NARROWING,
                  "32 samples in a window narrowing from the whole ray (r = 1) to r = 0.3 "
                  "over Hi's first 100 steps"),
          Variant("fine_32+32", "halo", _FINE,
                  "32 samples in r = 0.3, then 32 drawn from their weights, composited "
                  "together (NeRF's fine pass in the window; fewer steps in the same time)"),
          Variant(f"dense_eval_{DENSE_EVAL_AFTER}", "halo", _window() + _DENSE_EVAL,
                  f"trained as `halo`; once Hi has trained {DENSE_EVAL_AFTER} steps (past its "
                  "steps at 240 s on every scene here, short of them at 960 s), its held-out "
                  "views are rendered with 64 samples stratified over the whole ray"),
          Variant(f"samples_64_after_{SAMPLES_SWITCH}", "halo", _window() + _SAMPLES_64,
                  f"32 samples in r = 0.3 for Hi's first {SAMPLES_SWITCH} steps, then 64 "
                  "(trained and scored so; fewer steps in the same time past the switch)"),
          Variant(f"full_8+samples_64_after_{SAMPLES_SWITCH}", "halo",
                  _window(full=8) + _SAMPLES_64,
                  f"`full_8` (fern_4view's default) for Hi's first {SAMPLES_SWITCH} steps, then "
                  "8 of 64 over the whole ray and the rest in r = 0.3"),
          Variant(f"samples_64_after_{SAMPLES_SWITCH}+dense_eval_128", "halo",
                  _window() + _SWITCHED_DENSE_EVAL,
                  f"trained as `samples_64_after_{SAMPLES_SWITCH}`; once Hi has trained "
                  f"{SAMPLES_SWITCH} steps, its held-out views are rendered with 128 samples "
                  "stratified over the whole ray (what the baseline's twin trains and renders "
                  "with)", against=f"samples_64_after_{SAMPLES_SWITCH}"),
          BASELINE_UNSWITCHED,
          Variant(f"nerf_tuned_dense_eval_{DENSE_EVAL_AFTER}", "nerf_tuned", _BASELINE_DENSE_EVAL,
                  f"the baseline, trained as it is; once it has trained {DENSE_EVAL_AFTER} "
                  "steps, its held-out views are rendered with twice its 64 samples (the "
                  "same chance)"),
          Variant(BASELINE_TWIN, "nerf_tuned", _BASELINE_SAMPLES_128,
                  f"the baseline with twice its 64 samples once it has trained "
                  f"{SAMPLES_SWITCH} steps (the same chance as HALO's switch)"),
          Variant(f"{BASELINE_TWIN}+dense_eval_256", "nerf_tuned",
                  _BASELINE_SWITCHED_DENSE_EVAL,
                  f"trained as `{BASELINE_TWIN}`; once it has trained {SAMPLES_SWITCH} steps, its "
                  "held-out views are rendered with 256 samples (twice those it trains with: "
                  "the same chance)", against=BASELINE_TWIN),
      ),
      reference="halo", seeds=2, budget="time", front=False, budget_s=budget_s)


def _ndc_ray_study(budget_s: float) -> Study:
  """The forward-facing ray field on random rays, at one budget of the
  budget study."""
  fern = tuple(s for s in suites.VALIDATION_SCENES if s.name == "fern_4view")
  return Study(
      title=f"Forward-facing scenes: the ray field on random rays, {budget_s:g} reference seconds",
      question=("Whether the ray field that places Hi-NeRF's samples on a forward-facing "
                "scene misses Lo's surface less when half of each of its batches are random "
                "rays between the training rays (the paper trains it on random rays; ours "
                "saw only training rays), alone and with 8 of Hi's samples over the whole "
                "ray."),
      scenes=fern,
      variants=(
          Variant("halo", "halo", (("ray.random_fraction", 0.0), ("ray.bank_rays", 0))
                  + _window(), "the ray field on training rays only (the CPU config)"),
          Variant("ray_random_0.5", "halo",
                  (("ray.random_fraction", 0.5), ("ray.bank_rays", 32768)) + _window(),
                  "half of each ray-field batch from 32768 random rays between the training "
                  "rays, rendered once by Lo"),
          Variant("ray_random_0.5+full_8", "halo",
                  (("ray.random_fraction", 0.5), ("ray.bank_rays", 32768))
                  + _window(full=8), "both: random rays, and 8 of Hi's 32 samples over the ray"),
          BASELINE,
      ),
      reference="halo", seeds=2, budget="time", front=False, budget_s=budget_s)


def _dynamic_hi(lr=5e-4, time_L=8, empty=0.1, freq_reg=0.0):
  """The overrides of a D-NeRF Hi: its rate, time frequencies, L_empty weight
  and FreeNeRF's mask on its own P.E. bands (Lo's stay open)."""
  return _hi_lr(lr) + (("hi.encoding.time_L", time_L), ("hi.empty.weight", empty),
                       ("hi.freq_reg.end", freq_reg))


# The sphere kind's Lo start (methods/halo.py) on a dynamic scene, and Hi uncropped.
_NO_CROP = (("lo.precrop_steps", 0), ("lo.fg_steps", 200), ("lo.fg_fraction", 0.5),
            ("hi.precrop_steps", 0))


def _dynamic_hi_study(budget_s: float) -> Study:
  """D-NeRF: what keeps Hi-NeRF at or above its own Lo, at one budget of the
  budget study."""
  return Study(
      title=f"D-NeRF: Hi-NeRF at or above its own Lo-NeRF, {budget_s:g} reference seconds",
      question=("Whether Hi-NeRF, started as Lo-NeRF's exact copy on a dynamic scene, ends "
                "at or above Lo on every D-NeRF scene's val frames with a lower rate, with "
                "its time encoding kept at Lo's low frequency, or with L_empty five times "
                "stronger (a prior that acts for the whole run); nerf_tuned gets the time "
                "encoding's change too."),
      scenes=tuple(s for s in suites.VALIDATION_SCENES if s.name.startswith("dnerf_")),
      variants=(
          Variant("halo", "halo", _dynamic_hi(),
                  "Hi at 5e-4 -> 5e-5, time_L 8, L_empty 0.1 (the CPU config)"),
          Variant("hi_lr_2.5e-4", "halo", _dynamic_hi(lr=2.5e-4), "Hi at 2.5e-4 -> 2.5e-5"),
          Variant("hi_time_L_4", "halo", _dynamic_hi(time_L=4),
                  "Hi's time encoding at Lo's 4 frequencies (space keeps 10)"),
          Variant("empty_0.5", "halo", _dynamic_hi(empty=0.5), "L_empty at 0.5"),
          Variant("hi_no_crop", "halo", _dynamic_hi() + (("hi.precrop_steps", 0),),
                  "Hi, started as Lo's copy, on whole images from its first step (no "
                  "centre crop)"),
          Variant("hi_crop_50", "halo", _dynamic_hi() + (("hi.precrop_steps", 50),),
                  "Hi, started as Lo's copy, on the centre crop for its first 50 steps "
                  "(of 200)"),
          Variant("no_crop+fg_start", "halo", _dynamic_hi() + _NO_CROP,
                  "no centre crop for Lo or Hi; half of Lo's first 200 batches from the "
                  "foreground (the sphere kind's start)"),
          Variant("freq_reg_0.9", "halo", _dynamic_hi(freq_reg=0.9),
                  "Hi's own P.E. bands (Lo's always open) opening one after another over "
                  "90% of its steps (FreeNeRF's mask)"),
          BASELINE,
          Variant("nerf_tuned_time_L_4", "nerf_tuned", (("hi.encoding.time_L", 4),),
                  "the baseline with 4 time frequencies"),
          Variant("nerf_tuned_no_crop", "nerf_tuned", (("hi.precrop_steps", 0),),
                  "the baseline without the centre crop"),
      ),
      reference="halo", seeds=2, budget="time", front=False, budget_s=budget_s)


def hi_steps(scene: suites.Scene, budget_s: float, method: str = "halo") -> int:
  """The steps `method`'s Hi-NeRF (halo's by default) trains on `scene` at
  `budget_s` reference seconds (the committed step table's count)."""
  import dataclasses  # pylint: disable=import-outside-toplevel
  from experiments.bench import benchmark  # pylint: disable=import-outside-toplevel
  terms = dataclasses.replace(suites.CPU, budget_s=budget_s)
  return protocol.effective(benchmark.configure(terms, scene, method, 0, "budget",
                                                "/tmp/halo_study_steps")).hi.budget_steps


def _knights_steps_study(budget_s: float) -> Study:
  """knights: how much of nerf_tuned's lead is the steps HALO's costlier
  step leaves out, at one budget of the budget study."""
  knights = tuple(s for s in suites.VALIDATION_SCENES if s.name == "knights")
  steps = hi_steps(knights[0], budget_s)
  return Study(
      title=f"knights: nerf_tuned at HALO's step count, {budget_s:g} reference seconds",
      question=("How much of nerf_tuned's lead on the light field is the steps it gains "
                "because HALO's step (its ray field trained with the stage) costs more: "
                "nerf_tuned stopped at the steps halo trains in the same reference time "
                "(its schedules as written), so that the two differ only by what a step "
                "does."),
      scenes=knights,
      variants=(
          Variant("halo", "halo", (), "the CPU config"),
          BASELINE,
          Variant("nerf_tuned_halo_steps", "nerf_tuned", (("hi.stop_at_step", steps),),
                  f"the baseline stopped at halo's {steps} steps"),
      ),
      reference="halo", seeds=2, budget="time", front=False, budget_s=budget_s)


def _lo_teacher_study(kind: str, budget_s: float) -> Study:
  """Lo-NeRF as Hi-NeRF's teacher for the whole of Hi's run (L_teach,
  halo_jax/stages/teach.py) on every validation scene of `kind` ('dynamic':
  D-NeRF, where Hi ends below its own Lo, first; '360': the static sphere
  scenes), at one budget of the budget study."""
  scenes = (tuple(s for s in suites.VALIDATION_SCENES if s.name.startswith("dnerf_"))
            if kind == "dynamic" else suites.VALIDATION_360)
  return Study(
      title=f"Lo-NeRF as Hi-NeRF's teacher ({kind}), {budget_s:g} reference seconds",
      question=("Whether Hi-NeRF keeps Lo's gain to the end when, on random rays where "
                "Lo-NeRF is sure of a surface (opaque on the ray and its neighbour in time "
                "or direction, at one depth), Hi's depth and opacity follow Lo's with a "
                "weight that falls to 0 at Hi's last step; on every validation scene of "
                f"the kind ({kind}); nerf_tuned's runs are the budget study's."),
      scenes=scenes,
      variants=(
          Variant("halo", "halo", (("hi.teach.weight", 0.0),), "HALO as it is"),
          Variant("teach_0.1", "halo+teach", (("hi.teach.weight", 0.1),),
                  "L_teach at 0.1, falling to 0 over Hi's steps"),
          Variant("teach_1", "halo+teach", (("hi.teach.weight", 1.0),),
                  "L_teach at 1, falling to 0 over Hi's steps"),
      ),
      reference="halo", seeds=2, budget="time", front=False, budget_s=budget_s)


# Each family is one question asked at every budget of the budget study:
# {family: the study at a budget}. A variant is judged over its family
# (default_rule.judged_across): at each budget where it differs from the reference.
_FAMILIES = {
    "hi_window": _hi_window_study,
    "lo_teacher_dynamic": lambda b: _lo_teacher_study("dynamic", b),
    "lo_teacher_360": lambda b: _lo_teacher_study("360", b),
    "ndc_ray": _ndc_ray_study,
    "dynamic_hi": _dynamic_hi_study,
    "knights_steps": _knights_steps_study,
}
# {family: {budget_s: study name}}
FAMILIES = {f: {b: f"{f}_{b:g}" for b in suites.BUDGET_STUDY.values()} for f in _FAMILIES}
STUDIES = {name: _FAMILIES[f](b) for f, names in FAMILIES.items() for b, name in names.items()}


def family_of(study_name: str) -> dict:
  """{budget_s: study name} of the family `study_name` belongs to ({} for a
  study asked at one budget only)."""
  return next((names for names in FAMILIES.values() if study_name in names.values()), {})
