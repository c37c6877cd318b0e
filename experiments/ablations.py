"""Ablation studies scored on validation views: which setting HALO should use.

A study is a set of scenes, variants (a method plus config overrides) and
seeds, run on the CPU suite's terms but at matched steps, and scored on views
the suite never scores: D-NeRF's `val` frames, the built-in scenes' `val`
cameras (datasets/procedural.py). Nothing here reads a test view.

Matched steps: each stage stops (`stop_at_step`) at the mean step count
the CPU suite's 240-s `halo` runs of the scene reached in that stage
(MATCHED_STEPS, frozen from the suite's files), with every schedule still spanning the
stage's `steps`, exactly as when the time cap stops it. So a study's runs
do not depend on what else the machine is doing, and two run side by side.
Each record keeps its training seconds, so a variant that makes steps
dearer shows it.

  python experiments/ablations.py --study=dnerf_hi [--only=REGEX] [--core=0|1]
  python experiments/ablations.py --study=fog --dry_run
  python experiments/ablations.py --study=fog --report_only

Each finished run writes results/ablations/<study>/<scene>/<variant>/seed<k>.json
(committed; a run whose file exists is skipped, a killed one resumes from
--scratch), and the report docs/results/ablation_<study>.md: per scene and
variant, the final stage's val PSNR (mean +- std over seeds), Lo-NeRF's val
PSNR at the end of its stage, the steps each stage trained, and the
difference from the study's reference variant.
"""
import dataclasses
import os
import statistics
import sys
import time
import traceback
from typing import Tuple

from absl import app, flags, logging

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
if __package__ in (None, ""):
  sys.path.insert(0, REPO)
from experiments import benchmark, code_version, fronts_report, report_common, run_file, selection, suites  # pylint: disable=g-import-not-at-top
from halo_jax import runs  # pylint: disable=g-import-not-at-top
from halo_jax.configure import set_field  # pylint: disable=g-import-not-at-top

FLAGS = flags.FLAGS


@dataclasses.dataclass(frozen=True)
class Variant:
  name: str
  method: str
  overrides: Tuple[Tuple[str, object], ...] = ()
  note: str = ""


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


def _terms(study: Study) -> suites.Suite:
  """The CPU suite's budget, core count and curve settings, on the study's
  scenes' validation views."""
  return dataclasses.replace(suites.CPU, scenes=study.scenes,
                             overrides=suites.CPU.overrides + suites.VALIDATION_VIEWS)


def _both(field, value):
  """The same override on Lo and Hi (Hi starts as Lo's exact copy, so model
  fields must agree)."""
  return ((f"lo.{field}", value), (f"hi.{field}", value))


# Each variant states every field it is about, so that it stays what it says
# when a default moves (methods/halo.py took two of these settings).
_NEUTRAL_START = _both("model.density_bias", -1.0)


def _hi_lr(lr):
  return (("hi.lr_init", lr), ("hi.lr_final", lr / 10))


_DNERF = tuple(s for s in suites.CPU.scenes if s.name.startswith("dnerf_"))
_PROCEDURAL = tuple(s for s in suites.CPU.scenes if s.name in ("spheres", "lattice"))


def _shares(lo, ray, hi):
  return (("budget_shares.lo", lo), ("budget_shares.ray", ray), ("budget_shares.hi", hi))

STUDIES = {
    "dnerf_hi": Study(
        title="D-NeRF: Hi-NeRF after a copy of Lo-NeRF",
        question=("Why HALO's Hi stage ends below its own Lo stage on dynamic scenes, and "
                  "which setting of Hi keeps Lo's gain."),
        scenes=_DNERF,
        variants=(
            Variant("halo", "halo", _hi_lr(2e-3) + _NEUTRAL_START,
                    "Hi at 2e-3 -> 2e-4 (the CPU rate), density softplus(raw - 1)"),
            Variant("hi_lr_5e-4", "halo", _hi_lr(5e-4) + _NEUTRAL_START,
                    "Hi at a quarter of the CPU rate"),
            Variant("hi_lr_1e-3", "halo", _hi_lr(1e-3) + _NEUTRAL_START,
                    "Hi at half the CPU rate"),
            Variant("halo+freenerf", "halo+freenerf", _hi_lr(2e-3) + _NEUTRAL_START,
                    "Hi's own P.E. bands open over 90% of Hi's steps"),
            Variant("hi_lr_5e-4+density_bias_-4", "halo",
                    _hi_lr(5e-4) + _both("model.density_bias", -4.0),
                    "Hi at a quarter of the CPU rate, and both NeRFs start at softplus(raw - 4)"),
        ),
        reference="halo", seeds=2),
    "lo_start": Study(
        title="360-degree scenes: Lo-NeRF's first steps, neither fog nor collapse",
        question=("Whether Lo-NeRF should train on the centre crop for its first steps: "
                  "without it (the fog fix) Lo can stay the empty field on a thin object; "
                  "with 200 steps of it Lo fogged spheres at seed 1."),
        scenes=suites.VALIDATION_360,
        variants=(
            Variant("halo", "halo", (("lo.precrop_steps", 0), ("lo.fg_steps", 0)),
                    "Lo on whole images from its first step"),
            Variant("lo_crop_100", "halo", (("lo.precrop_steps", 100), ("lo.fg_steps", 0)),
                    "Lo on the centre crop for its first 100 steps"),
            Variant("lo_fg_200", "halo", (("lo.precrop_steps", 0), ("lo.fg_steps", 200),
                                          ("lo.fg_fraction", 0.5)),
                    "half of each batch of Lo's first 200 steps from the pixels that are not "
                    "the white background, the rest from all pixels"),
            Variant("nerf_tuned", "nerf_tuned", note="the baseline, as in the suite"),
        ),
        reference="halo", seeds=2),
    "dnerf_hi_crop": Study(
        title="D-NeRF: Hi-NeRF's centre crop after the copy of Lo-NeRF",
        question=("Whether Hi-NeRF, started as Lo-NeRF's exact copy, should go back to the "
                  "centre crop for its first 200 steps (about half of its CPU steps; the "
                  "baseline's crop, and TiNeuVox has none), on every D-NeRF scene's val "
                  "frames."),
        scenes=tuple(s for s in suites.VALIDATION_SCENES if s.name.startswith("dnerf_")),
        variants=(
            Variant("halo", "halo", (("hi.precrop_steps", 200),),
                    "Hi on the centre crop for its first 200 steps (Lo's)"),
            Variant("hi_no_crop", "halo", (("hi.precrop_steps", 0),),
                    "Hi on whole images from the copy on"),
            Variant("nerf_tuned", "nerf_tuned", note="the baseline, as in the suite"),
        ),
        reference="halo", seeds=2),
    "fog": Study(
        title="Built-in scenes: Lo-NeRF's fog where no training ray passes",
        question=("What removes the density Lo-NeRF leaves where no training ray passes "
                  "(spheres at seed 1), and narrows lattice's spread over seeds."),
        scenes=_PROCEDURAL,
        variants=(
            Variant("halo", "halo", _NEUTRAL_START,
                    "softplus(raw - 1): ~0.31 per unit at the start"),
            Variant("density_bias_-4", "halo", _both("model.density_bias", -4.0),
                    "softplus(raw - 4): ~0.018 per unit at the start"),
            Variant("relu", "halo", _both("model.density_activation", "relu")
                    + _both("model.density_bias", 0.0), "ReLU density (the authors')"),
            Variant("halo+unseen", "halo+unseen", _NEUTRAL_START,
                    "L_unseen on Lo and Hi, weight 0.01 (methods/halo_unseen.py)"),
            Variant("density_bias_-4+unseen", "halo+unseen", _both("model.density_bias", -4.0),
                    "both: the empty start and L_unseen (weight 0.01)"),
            Variant("no_precrop", "halo", (("lo.precrop_steps", 0),) + _NEUTRAL_START,
                    "Lo trained on whole images from the first step (no centre crop)"),
            Variant("no_precrop+density_bias_-4", "halo",
                    (("lo.precrop_steps", 0),) + _both("model.density_bias", -4.0),
                    "no centre crop for Lo, and the empty start"),
            Variant("nerf_tuned", "nerf_tuned", note="the baseline, as in the suite"),
            Variant("nerf_tuned+density_bias_-4", "nerf_tuned",
                    (("hi.model.density_bias", -4.0),),
                    "the baseline started at softplus(raw - 4): does the start help it too?"),
        ),
        reference="halo", seeds=3),
    "static_hi": Study(
        title="Static scenes: HALO's Hi-NeRF beside the authors' choices",
        question=("Whether the authors' choices for Hi-NeRF, where ours differ, would do better "
                  "on the built-in scenes: the window tightened on the near side only, Hi "
                  "started without the exact copy (the layers reading the encoding fresh), and "
                  "L_empty from a later step."),
        scenes=_PROCEDURAL,
        variants=(
            Variant("halo", "halo", note="HALO as configured (an empty start, the exact copy)"),
            Variant("near_only", "halo", (("hi.sampler.near_only", True),),
                    "the depth-guided window tightened on the near side only (the authors')"),
            Variant("partial_copy", "halo",
                    (("hi.encoding.with_lo", False), ("hi.init_from_lo", True)),
                    "Hi from Lo's weights, the input layer fresh (our `init_from_lo` alone)"),
            Variant("empty_from_step_100", "halo", (("hi.empty.start_step", 100),),
                    "L_empty switched on after 100 of Hi's ~570 steps"),
        ),
        reference="halo", seeds=3),
    "hi_samples": Study(
        title="Static scenes: Hi-NeRF's samples per ray inside the ray field's window",
        question=("Whether the depth-guided Hi-NeRF can take fewer samples per ray than the "
                  "CPU config's 32 at equal steps (a cost under 0.1 dB), so that each step is "
                  "cheaper and HALO reaches a given error sooner."),
        scenes=_PROCEDURAL,
        variants=(
            Variant("halo", "halo", note="32 depth-guided samples (the CPU config)"),
            Variant("hi_samples_16", "halo", (("hi.sampler.num_samples", 16),),
                    "16 samples in the window"),
            Variant("hi_samples_8", "halo", (("hi.sampler.num_samples", 8),),
                    "8 samples in the window"),
        ),
        reference="halo", seeds=2),
    "sin_cos": Study(
        title="Static scenes: the encodings' sin and cos as polynomials or as XLA's",
        question=("Whether evaluating the encodings' sin and cos by the vectorised polynomials "
                  "(halo_jax/trig.py; on one CPU core Hi's step 11% and a render 33% cheaper) "
                  "instead of XLA's own functions costs accuracy at equal steps (the bar: under "
                  "0.1 dB)."),
        scenes=_PROCEDURAL,
        variants=(
            Variant("halo", "halo", note="the polynomials (the default)"),
            Variant("xla_sin_cos", "halo", (("sin_cos", "xla"),), "XLA's sin and cos"),
        ),
        reference="halo", seeds=2),
    "bf16": Study(
        title="Static scenes: Lo- and Hi-NeRF's layers with bfloat16 operands",
        question=("Whether the NeRF layers' matmuls with bfloat16 operands and float32 sums "
                  "(`model.compute_dtype`; on one CPU core with avx512_bf16 Lo's step 9% and "
                  "Hi's 11% cheaper, a render 30%) cost accuracy at equal steps (the bar: under "
                  "0.1 dB)."),
        scenes=_PROCEDURAL,
        variants=(
            Variant("halo", "halo", _both("model.compute_dtype", "float32"),
                    "float32 layers (the default)"),
            Variant("halo_bf16", "halo", _both("model.compute_dtype", "bfloat16"),
                    "bfloat16 operands, float32 sums, in Lo's and Hi's layers"),
        ),
        reference="halo", seeds=2),
    "lego_protocol": Study(
        title="lego's CPU protocol, re-chosen on lego's unused training views",
        question=("Whether the CPU protocol's settings that were first chosen on lego's test "
                  "views (Lo's P.E. scale, Hi as Lo's exact copy, Hi's 32 samples, the "
                  "window r = 0.3, Hi's and the baseline's 2e-3 rate) hold on views that are "
                  "neither training nor test views, on both lego protocols."),
        scenes=tuple(s for s in suites.VALIDATION_SCENES if s.name.startswith("lego_")),
        variants=(
            Variant("halo", "halo", note="the CPU config (L=5, s=1; exact copy; 32 samples; "
                    "r = 0.3; Hi at 2e-3 -> 2e-4)"),
            Variant("lo_scale_4", "halo", (("lo.encoding.scale", 4.0),),
                    "Lo's P.E. at s = 4 (higher frequencies)"),
            Variant("hi_fresh", "halo", (("hi.encoding.with_lo", False),
                                         ("hi.init_from_lo", False)),
                    "Hi trained from scratch, not as Lo's copy"),
            Variant("hi_samples_64", "halo", (("hi.sampler.num_samples", 64),),
                    "64 depth-guided samples (each step dearer)"),
            Variant("window_0.5", "halo", (("hi.sampler.window", 0.5),), "r = 0.5"),
            Variant("hi_lr_5e-4", "halo", _hi_lr(5e-4), "Hi at 5e-4 -> 5e-5"),
            Variant("nerf_tuned", "nerf_tuned", note="the baseline, as in the suite (2e-3)"),
            Variant("nerf_tuned_lr_5e-4", "nerf_tuned", _hi_lr(5e-4),
                    "the baseline at 5e-4 -> 5e-5"),
        ),
        reference="halo", seeds=2),
    "knights_window": Study(
        title="knights: the light-field window and the (u, v) frequency, on other grid views",
        question=("Whether the knights CPU config's window floor (alpha_final 0.1) and its "
                  "(u, v) frequency (uv_std 0.17), first chosen on the test views, hold on "
                  "grid views between the training corners that are not test views."),
        scenes=tuple(s for s in suites.VALIDATION_SCENES if s.name == "knights"),
        variants=(
            Variant("halo", "halo", note="alpha_final 0.1, uv_std 0.17 (the CPU config)"),
            Variant("alpha_final_0.25", "halo", (("hi.joint.alpha_final", 0.25),),
                    "the window's floor at 0.25"),
            Variant("alpha_final_0.5", "halo", (("hi.joint.alpha_final", 0.5),),
                    "the window's floor at 0.5 (the paper's full-size value)"),
            Variant("uv_std_0.08", "halo", (("hi.joint.uv_std", 0.08),),
                    "(u, v) frequency halved"),
            Variant("uv_std_0.34", "halo", (("hi.joint.uv_std", 0.34),),
                    "(u, v) frequency doubled"),
            Variant("nerf_tuned", "nerf_tuned", note="the baseline, as in the suite"),
        ),
        reference="halo", seeds=2),
    "authors_light_field": Study(
        title="Light fields and LLFF: HALO as the authors' code runs it against ours",
        question=("Whether the authors' light-field recipe (methods/halo_authors.py: their "
                  "axis-aligned encodings, a ray field as large as the radiance field with a "
                  "colour head and random rays, their blended window and half-even samples, "
                  "relu density with noise; on LLFF their joint light field on two planes "
                  "through the scene instead of our NDC pipeline) does better than ours "
                  "(`halo`) under the CPU protocol's time budget, on views that are neither "
                  "training nor test views, and whether either leads nerf_tuned by 1 dB."),
        scenes=tuple(s for s in suites.VALIDATION_SCENES if s.name in ("knights", "fern_4view")),
        variants=(
            Variant("halo", "halo", note="ours (the CPU config)"),
            Variant("halo_authors", "halo_authors", note="the authors' recipe at CPU size"),
            Variant("nerf_tuned", "nerf_tuned", note="the baseline, as in the suite"),
        ),
        reference="halo", seeds=2, budget="time", front=False),
    "authors_static": Study(
        title="360-degree scenes: HALO as the authors' code runs it against ours",
        question=("Whether the authors' static recipe (methods/halo_authors.py: Lo with the "
                  "centre crop, Lo's depth target with the light past the last sample at far, "
                  "a view-independent Hi from scratch in a near-side window, Hi's crop, the "
                  "Poly schedule, L_empty with noise and a later start, their per-scene "
                  "loads) does better than ours (`halo`) under the CPU protocol's time "
                  "budget, on every 360-degree scene kind with views that are neither "
                  "training nor test views."),
        scenes=suites.VALIDATION_360,
        variants=(
            Variant("halo", "halo", note="ours (the CPU config)"),
            Variant("halo_authors", "halo_authors", note="the authors' recipe at CPU size"),
        ),
        reference="halo", seeds=2, budget="time", front=False),
    "static_front": Study(
        title="Static scenes: what lifts HALO's front under the time budget",
        question=("Whether HALO reaches nerf_tuned's final PSNR sooner when Lo-NeRF gets less "
                  "of the budget (its front flattens before its 72 s end), so that Hi-NeRF "
                  "starts sooner, or when Hi-NeRF, an exact copy of Lo-NeRF, trains at a lower "
                  "rate, as on the dynamic scenes, or when both methods' layers take bfloat16 "
                  "operands; without a loss at the end of the budget."),
        scenes=_PROCEDURAL,  # the static scenes with validation views here
        variants=(
            Variant("halo", "halo", _shares(0.30, 0.07, 0.63) + _hi_lr(2e-3),
                    "Lo 30%, ray field 7%, Hi 63% of the budget; Hi at 2e-3 -> 2e-4 "
                    "(the CPU config)"),
            Variant("shares_20_05_75", "halo", _shares(0.20, 0.05, 0.75),
                    "Lo 20%, ray field 5%, Hi 75%"),
            Variant("shares_15_05_80", "halo", _shares(0.15, 0.05, 0.80),
                    "Lo 15%, ray field 5%, Hi 80%"),
            Variant("hi_lr_1e-3", "halo", _hi_lr(1e-3), "Hi at half the CPU rate"),
            Variant("hi_lr_5e-4", "halo", _hi_lr(5e-4),
                    "Hi at a quarter of the CPU rate (the paper's, as on dynamic scenes)"),
            Variant("nerf_tuned", "nerf_tuned", note="the baseline, as in the suite"),
            Variant("bf16", "halo", _both("model.compute_dtype", "bfloat16"),
                    "Lo's and Hi's layers with bfloat16 operands (study bf16)"),
            Variant("nerf_tuned_bf16", "nerf_tuned", (("hi.model.compute_dtype", "bfloat16"),),
                    "the baseline's layers with bfloat16 operands"),
        ),
        reference="halo", seeds=1, budget="time"),
}


def _plan(study: Study, only: str):
  """[(scene, variant, seed), ...] filtered by the regex `only` (ValueError
  when it is not one, or selects nothing)."""
  runs = [(scene, v, seed) for seed in range(study.seeds) for scene in study.scenes
          for v in study.variants]
  return selection.select(runs, lambda r: f"{r[0].name}/{r[1].name}/seed{r[2]}", only,
                          part="variant", plan="study")


def result_path(results, study_name, scene, variant, seed):
  return os.path.join(results, "ablations", study_name, scene.name, variant.name,
                      f"seed{seed}.json")


# {scene: {stage: steps}}: the mean steps the CPU suite's 240-s `halo` runs
# reached per stage (2-3 seeds, results/cpu/time at commit 8ba0978), frozen
# here so that a study means the same runs whatever the suite holds now.
MATCHED_STEPS = {
    "lego_8view": {"lo": 475, "ray": 711, "hi": 581},
    "dnerf_lego": {"lo": 361, "hi": 428},
    "dnerf_hook": {"lo": 348, "hi": 403},
    "dnerf_jumpingjacks": {"lo": 365, "hi": 424},
    "lattice": {"lo": 484, "ray": 752, "hi": 586},
    "spheres": {"lo": 466, "ray": 732, "hi": 570},
    "lego_oneside": {"lo": 469, "ray": 375, "hi": 570},
    "fern_4view": {"lo": 494, "ray": 1, "hi": 832},
    "knights": {"hi": 1953},
    # the stress scenes: spheres' steps (the same image size and models)
    "thin": {"lo": 466, "ray": 732, "hi": 570},
    "sparse": {"lo": 466, "ray": 732, "hi": 570},
    "dnerf_hellwarrior": {"lo": 348, "hi": 403},  # hook's: the same frame count and size
}


def matched_steps(results: str, scene: suites.Scene) -> dict:
  """{stage: steps} a study's run of `scene` stops each stage at
  (MATCHED_STEPS). `results` is unused; kept for the call sites."""
  del results
  if scene.name not in MATCHED_STEPS:
    raise KeyError(f"no matched steps for scene {scene.name!r}: add it to "
                   "experiments/ablations.py MATCHED_STEPS")
  return dict(MATCHED_STEPS[scene.name])


def configure(study: Study, scene: suites.Scene, variant: Variant, seed: int, scratch: str,
              results: str):
  c = benchmark.configure(_terms(study), scene, variant.method, seed, "time", scratch)
  for field, value in variant.overrides:
    set_field(c, field, value)
  if study.budget == "time":
    if not study.front:
      c.eval.front_s = ()
    return c
  c.budget_s = 0.0
  for n, steps in matched_steps(results, scene).items():
    steps = max(steps, c[n].min_steps)  # a suite run that trained less than the floor
    c[n].update(max_seconds=0.0, eval_every_s=0.0, stop_at_step=steps,
                eval_every=max(1, steps // 2))
  return c


def run_one(study_name, study, scene, variant, seed, results, scratch) -> dict:
  c = configure(study, scene, variant, seed, scratch, results)
  workdir = os.path.join(scratch, "ablations", study_name, scene.name, variant.name,
                         f"seed{seed}")
  start = time.time()
  record = runs.run_method(c, workdir)
  record.pop("per_view", None)
  if study.budget == "time" and study.front:
    record["front"] = benchmark.front_points(workdir, record, with_lpips=False)
  record.update(study=study_name, scene=scene.name, config=scene.config, variant=variant.name,
                method=variant.method, overrides=[list(o) for o in variant.overrides],
                split=c.data.test_split, seed=seed,
                stop_at_step={n: c[n].stop_at_step for n in record["stages"]},
                run_seconds=round(time.time() - start, 1))
  run_file.write_json(result_path(results, study_name, scene, variant, seed), record)
  return record


def read_records(results, study_name):
  """{(scene, variant): [record, ...]} of a study's finished runs."""
  import json  # pylint: disable=g-import-not-at-top
  root = os.path.join(results, "ablations", study_name)
  out = {}
  if not os.path.isdir(root):
    return out
  for dirpath, _, files in os.walk(root):
    for f in sorted(files):
      if f.endswith(".json"):
        with open(os.path.join(dirpath, f)) as fh:
          r = json.load(fh)
        out.setdefault((r["scene"], r["variant"]), []).append(r)
  return out


def _mean_std(xs):
  if not xs:
    return ""
  if len(xs) == 1:
    return f"{xs[0]:.2f}"
  return f"{statistics.mean(xs):.2f} ± {statistics.stdev(xs):.2f}"


def _pairs(study: Study, recs, variant: str) -> list:
  """[(record, reference record), ...]: `variant`'s runs beside the
  reference's run of the same scene and seed, over every pair both ran."""
  out = []
  for scene in study.scenes:
    ref = {r["seed"]: r for r in recs.get((scene.name, study.reference), [])}
    out += [(r, ref[r["seed"]]) for r in recs.get((scene.name, variant), []) if r["seed"] in ref]
  return out


def _overall(study: Study, recs) -> list:
  """Lines of a table: per variant, its difference from the reference over
  every (scene, seed) both ran, and how many of those it lost."""
  rows = []
  for v in study.variants:
    if v.name == study.reference:
      continue
    deltas = [r["psnr"] - ref["psnr"] for r, ref in _pairs(study, recs, v.name)]
    if deltas:
      rows.append(f"| `{v.name}` | {len(deltas)} | {statistics.mean(deltas):+.2f} | "
                  f"{min(deltas):+.2f} | {sum(d < 0 for d in deltas)} |")
  if not rows:
    return []
  return ["", "## Over all scenes and seeds", "",
          f"Each variant against `{study.reference}` over the (scene, seed) pairs both ran.", "",
          "| variant | pairs | mean Δ | worst Δ | pairs lost |", "|---|---|---|---|---|"] + rows


# The rule a default's change must pass (docs/validation.md): measured on at
# least MIN_SEEDS seeds of every scene of the kind it applies to, it may lose
# no more than MAX_LOSS_DB (mean over seeds) on any of them.
MIN_SEEDS, MAX_LOSS_DB = 2, 0.3


def default_rule(study: Study, recs, variant: str) -> str:
  """Whether `variant` may replace the reference as the default: 'passes',
  'fails: <scenes and their mean Δ>' or 'not measured: <scenes short of
  seeds>'."""
  by_scene = {}
  for r, ref in _pairs(study, recs, variant):
    by_scene.setdefault(r["scene"], []).append(r["psnr"] - ref["psnr"])
  short, losses = [], []
  for scene in study.scenes:
    deltas = by_scene.get(scene.name, [])
    if len(deltas) < MIN_SEEDS:
      short.append(scene.name)
    elif statistics.mean(deltas) < -MAX_LOSS_DB:
      losses.append(f"{scene.name} {statistics.mean(deltas):+.2f}")
  if losses:
    return "fails: " + ", ".join(losses)
  if short:
    return "not measured: " + ", ".join(short)
  return "passes"


def _rule_lines(study: Study, recs) -> list:
  rows = [f"| `{v.name}` | {default_rule(study, recs, v.name)} |" for v in study.variants
          if v.name != study.reference and v.method == study.variants[0].method]
  if not rows:
    return []
  return ["", "## Against the default rule", "",
          f"A variant may replace `{study.reference}` only if, on at least {MIN_SEEDS} seeds of "
          f"every scene of the study, its mean loss on no scene exceeds {MAX_LOSS_DB} dB "
          "(docs/validation.md).", "", "| variant | verdict |", "|---|---|"] + rows


def _overall_fronts(study: Study, recs) -> list:
  """Lines of a table for a time study: per variant, its mean difference
  from the reference at each front time and at the end, over every (scene,
  seed) both ran."""
  times = sorted({p["at_s"] for rs in recs.values() for r in rs for p in r.get("front", [])
                  if not p.get("final")})
  rows = []
  for v in study.variants:
    if v.name == study.reference:
      continue
    deltas = {t: [] for t in times + [None]}
    for r, ref in _pairs(study, recs, v.name):
      for t in deltas:
        ours, theirs = fronts_report.front_values([r], t), fronts_report.front_values([ref], t)
        if ours and theirs:
          deltas[t].append(ours[0] - theirs[0])
    if deltas[None]:
      rows.append(f"| `{v.name}` | {len(deltas[None])} | " + " | ".join(
          f"{statistics.mean(d):+.2f}" if d else "-" for d in deltas.values()) + " |")
  if not rows:
    return []
  head = ["variant", "pairs"] + [f"{t:g} s" for t in times] + ["end"]
  return ["", f"Mean difference from `{study.reference}` at each saved time, validation views:",
          "", "| " + " | ".join(head) + " |", "|" + "---|" * len(head)] + rows


def _terms_text(study: Study) -> str:
  if study.budget == "time":
    return (f"CPU suite terms: {suites.CPU.budget_s:g} s of training on one core"
            + (", each run's state saved at the suite's front times" if study.front else
               ", scored at the end"))
  return ("CPU suite terms at matched steps (each stage stops at the steps the suite's "
          f"{suites.CPU.budget_s:g}-s `halo` runs of the scene reached, its schedules "
          "unchanged)")


def report(study_name: str, study: Study, results: str) -> str:
  """The study's page (markdown), from its result files."""
  recs = read_records(results, study_name)
  lines = [f"# Ablation: {study.title}", "",
           f"Generated by `experiments/ablations.py --study={study_name} --report_only` from "
           f"`results/ablations/{study_name}/`; do not edit.", "",
           study.question, "",
           _terms_text(study) + ", scored on validation views, never on the test views the "
           "suite reports: D-NeRF's `val` frames, the built-in scenes' `val` cameras. "
           "PSNR of the method's "
           "output, mean ± std over seeds; `Lo` is Lo-NeRF's PSNR at the end of its stage on "
           "the same views; `train s` the training seconds (mean; runs shared the machine); `Δ` the difference "
           f"from `{study.reference}` over the seeds both have.", "",
           "| variant | what it changes |", "|---|---|"]
  for v in study.variants:
    lines.append(f"| `{v.name}` | {v.note or ', '.join(f'{k}={x}' for k, x in v.overrides)} |")
  for scene in study.scenes:
    rows = [(v, recs.get((scene.name, v.name), [])) for v in study.variants]
    if not any(r for _, r in rows):
      continue
    ref = {r["seed"]: r for r in recs.get((scene.name, study.reference), [])}
    lines += ["", f"## {scene.name}", "",
              "| variant | seeds | PSNR | Lo PSNR | final - Lo | Δ | train s |",
              "|---|---|---|---|---|---|---|"]
    for v, rs in rows:
      if not rs:
        lines.append(f"| `{v.name}` | 0 | | | | | |")
        continue
      final = [r["psnr"] for r in rs]
      lo = [r["stages"]["lo"]["psnr"] for r in rs if "psnr" in r["stages"].get("lo", {})]
      drop = [r["psnr"] - r["stages"]["lo"]["psnr"] for r in rs
              if "psnr" in r["stages"].get("lo", {})]
      delta = [r["psnr"] - ref[r["seed"]]["psnr"] for r in rs if r["seed"] in ref]
      steps = f"{statistics.mean(r['wall_s'] for r in rs):.0f}"
      lines.append(f"| `{v.name}` | {len(rs)} | {_mean_std(final)} | {_mean_std(lo)} | "
                   f"{f'{statistics.mean(drop):+.2f}' if drop else ''} | "
                   f"{f'{statistics.mean(delta):+.2f}' if delta and v.name != study.reference else ''}"
                   f" | {steps} |")
    if study.budget == "time" and study.front:
      lines += ["", "Error against training time on every validation view (the run's state "
                "saved at these seconds, scored after training):", "",
                fronts_report.front_table({v.name: rs for v, rs in rows if rs})]
    per_seed = sorted({r["seed"] for _, rs in rows for r in rs})
    if len(per_seed) > 1:
      lines += ["", "Per seed: " + "; ".join(
          f"`{v.name}` " + ", ".join(f"s{r['seed']} {r['psnr']:.2f}"
                                     for r in sorted(rs, key=lambda r: r["seed"]))
          for v, rs in rows if rs) + "."]
  lines += _overall(study, recs)
  lines += _rule_lines(study, recs)
  lines += [""] + report_common.collapse_lines(
      [(f"{scene}/{variant}/seed{r['seed']}", r) for (scene, variant), rs in sorted(recs.items())
       for r in rs])
  if study.budget == "time" and study.front:
    lines += _overall_fronts(study, recs)
  commits = sorted({(r["provenance"].get("git") or {}).get("commit", "?")[:7]
                    for rs in recs.values() for r in rs})
  if commits:
    lines += ["", f"Commits: {', '.join(commits)}."]
  lines += _fingerprint_lines(study, recs)
  return "\n".join(lines) + "\n"


def _fingerprint_lines(study: Study, recs) -> list:
  """Per variant, the code fingerprints of its method that its runs measure
  (experiments/code_version.py): a variant whose runs span two fingerprints,
  or whose tree was modified or never measured, says so. A study's overrides
  are not part of a fingerprint, so a change of a default the study sets
  itself can mark its runs as different code without moving them."""
  table = code_version.load()
  rows = []
  for v in study.variants:
    rs = [r for (_, name), rr in sorted(recs.items()) if name == v.name for r in rr]
    if rs:
      rows.append(f"`{v.name}` {code_version.of_records(rs, table)}")
  return ["", "Code fingerprints (per variant, of its method): " + "; ".join(rows) + "."] if rows \
      else []


def define_flags():
  """This script's own flags; --only, --results, --scratch and --dry_run are
  experiments/benchmark.py's (imported above), with the same meaning."""
  flags.DEFINE_enum("study", "fog", sorted(STUDIES), "Study to run.")
  flags.DEFINE_string("docs", os.path.join(REPO, "docs", "results"), "Report folder.")
  flags.DEFINE_integer("core", -1, "Pin to this one core (-1: the machine's last).")
  flags.DEFINE_bool("report_only", False, "Write the report from the result files only.")


def main(argv):
  del argv
  logging.set_verbosity(logging.WARNING)
  study = STUDIES[FLAGS.study]
  if not FLAGS.report_only:
    if hasattr(os, "sched_setaffinity"):
      allowed = sorted(os.sched_getaffinity(0))
      os.sched_setaffinity(0, [allowed[FLAGS.core]])
    try:
      todo = _plan(study, FLAGS.only)
    except ValueError as e:
      sys.exit(str(e))
    failed = []
    for scene, variant, seed in todo:
      path = result_path(FLAGS.results, FLAGS.study, scene, variant, seed)
      tag = f"{scene.name}/{variant.name}/seed{seed}"
      state = benchmark._state(path, scene, _terms(study))  # pylint: disable=protected-access
      if FLAGS.dry_run or state != "to run":
        print(f"{state:8} {tag}", flush=True)
        continue
      try:
        r = run_one(FLAGS.study, study, scene, variant, seed, FLAGS.results, FLAGS.scratch)
      except Exception:  # pylint: disable=broad-except
        traceback.print_exc()
        print(f"FAILED   {tag}", flush=True)
        failed.append(tag)
        continue
      lo = r["stages"].get("lo", {}).get("psnr")
      print(f"ran      {tag}: {r['psnr']:.2f}" + (f" (Lo {lo:.2f})" if lo else "") +
            "  steps " + ", ".join(f"{n} {s['step']}" for n, s in r["stages"].items()),
            flush=True)
    if failed:
      sys.exit(f"{len(failed)} run(s) failed: {', '.join(failed)}")
  if FLAGS.dry_run:
    return
  text = report(FLAGS.study, study, FLAGS.results)
  os.makedirs(FLAGS.docs, exist_ok=True)
  with open(os.path.join(FLAGS.docs, f"ablation_{FLAGS.study}.md"), "w") as f:
    f.write(text)
  print(text)


if __name__ == "__main__":
  define_flags()
  app.run(main)
