"""The ablation studies: for each, its question, scenes, variants (a method
plus config overrides), reference variant and seeds (run by ablations.py).

Each variant states every field it is about, so that it stays what it says
when a default moves.
"""
from experiments.bench import budget_studies, suites
from experiments.bench.study_types import (BASELINE, NEUTRAL_START as _NEUTRAL_START, Study,  # noqa: F401
                                        Variant, both as _both, hi_lr as _hi_lr)

_DNERF = tuple(s for s in suites.CPU.scenes if s.name.startswith("dnerf_"))
_PROCEDURAL = tuple(s for s in suites.CPU.scenes if s.name in ("spheres", "lattice"))


# halo's two starts, as overrides of the authors' recipe
_FG_START = (("lo.precrop_steps", 0), ("lo.fg_steps", 200), ("lo.fg_fraction", 0.5))
_LO_COPY = (("hi.encoding.with_lo", True), ("hi.init_from_lo", True),
            ("hi.init_skip_fresh", False))


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
            BASELINE,
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
            BASELINE,
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
            BASELINE,
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
                    (("hi.copy_lo_under_budget", False), ("hi.encoding.with_lo", False),
                     ("hi.init_from_lo", True)),
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
            Variant("hi_fresh", "halo", (("hi.copy_lo_under_budget", False),
                                         ("hi.encoding.with_lo", False),
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
            BASELINE,
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
            BASELINE,
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
            # two of halo's departures, one at a time, in the authors' recipe
            Variant("halo_authors+fg_start", "halo_authors", _FG_START,
                    "Lo without the centre crop, half of its first 200 batches from the "
                    "foreground (halo's start)"),
            Variant("halo_authors+lo_copy", "halo_authors", _LO_COPY,
                    "Hi reads Lo's encoding beside its own and starts from all of Lo's "
                    "weights (halo's start)"),
            Variant("halo_authors+both_starts", "halo_authors", _FG_START + _LO_COPY,
                    "both of halo's starts in the authors' recipe"),
            Variant("halo_authors+lo_scale_32", "halo_authors", (("lo.encoding.scale", 32.0),),
                    "their Lo-P.E. scale (32, as at paper size) instead of the CPU scenes' 1"),
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
            BASELINE,
            Variant("bf16", "halo", _both("model.compute_dtype", "bfloat16"),
                    "Lo's and Hi's layers with bfloat16 operands (study bf16)"),
            Variant("nerf_tuned_bf16", "nerf_tuned", (("hi.model.compute_dtype", "bfloat16"),),
                    "the baseline's layers with bfloat16 operands"),
        ),
        reference="halo", seeds=1, budget="time"),
    **budget_studies.STUDIES,
}


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

# The studies run at each budget of the budget study (budget_studies.py).
BUDGET_STUDIES = tuple(budget_studies.STUDIES)
