"""HALO's margin at the largest budget against the baseline without and with
the same chance: nerf_tuned with twice its samples once it has trained as
long as HALO's Hi before its sampler switch (budget_studies.BASELINE_TWIN)
beside nerf_tuned without a switch (BASELINE_UNSWITCHED), both run in the
`hi_window` study on validation views. Tells HALO's gain from the switch
apart from any NeRF's gain from more samples late."""
import numpy as np

from experiments.bench import budget_studies, code_version, default_rule, study_records

METHOD, BASELINE = "halo", "nerf_tuned"
UNSWITCHED = budget_studies.BASELINE_UNSWITCHED.name


def rows(runs, recs) -> list:
  """[(scene, seeds, halo, nerf_tuned without the switch, nerf_tuned as the
  suite runs it)]: the mean PSNR of each over the seeds all three ran, for
  every scene of `runs` ({scene: {method: [record]}}, the budget suite's)
  where the study's records `recs` ({(scene, variant): [record]}) have the
  twin; the baseline without the switch is the study's."""
  out = []
  for scene, by in runs.items():
    if not recs.get((scene, budget_studies.BASELINE_TWIN)):
      continue
    psnr = [{r["seed"]: r["psnr"] for r in rs} for rs in (
        by.get(METHOD, []), recs.get((scene, UNSWITCHED), []), by.get(BASELINE, []))]
    seeds = sorted(set(psnr[0]) & set(psnr[1]) & set(psnr[2]))
    if seeds:
      out.append((scene, seeds, *(float(np.mean([d[k] for k in seeds])) for d in psnr)))
  return out


def section(runs, results: str, budget_s: float) -> list:
  """The budget page's lines on HALO's margin at equal chance at `budget_s`
  ([] before any twin has run): per scene and per kind, halo less the
  baseline without and with the switch, and whether the switch passes the
  default rule as the baseline's default on each scene geometry."""
  name = f"hi_window_{budget_s:g}"
  recs = study_records.read(results, name)
  table = rows(runs, recs)
  if not table:
    return []
  lines, kinds = [], {}
  for scene, seeds, halo, base, twin in table:
    kinds.setdefault(code_version.kind_of(runs[scene][METHOD][0]["config"]), []).append(
        (halo - base, halo - twin))
    lines.append(f"| {scene} | {', '.join(map(str, seeds))} | {halo:.2f} | {base:.2f} | "
                 f"{twin:.2f} | {halo - base:+.2f} | {halo - twin:+.2f} |")
  study = budget_studies.STUDIES[name]
  verdicts = {k: default_rule.verdict(study, recs, budget_studies.BASELINE_TWIN,
                                      reference=UNSWITCHED, scenes=s)
              for k, s in default_rule.by_kind(study, recs).items()}
  both = np.asarray([(h - b, h - t) for _, _, h, b, t in table])
  adopted = sorted({s for s, by in runs.items() for r in by.get(BASELINE, [])
                    if budget_studies.BASELINE_TWIN in (r.get("adopted_from") or {}).get("path", "")})
  now = (f" The suite's {BASELINE} runs above are the twin's runs, adopted (its default on "
         f"{', '.join(adopted)}; where the record is rescored, rendered past the switch with "
         "twice its samples: `rescored_from`)." if adopted else "")
  return [f"### At equal chance: {UNSWITCHED} with the same switch", "",
          f"HALO's Hi takes twice its samples once it has trained "
          f"{budget_studies.SAMPLES_SWITCH} steps, and its held-out views are then rendered "
          f"with twice those again, stratified over the whole ray. `{budget_studies.BASELINE_TWIN}` "
          f"gives {BASELINE} the same switch, from its own 64 samples, and its dense renders "
          f"are `+dense_eval_256` ([the `{name}` study](ablation_{name}.md): the same views and "
          f"budget). Per scene (the seeds all three ran; {METHOD} and {BASELINE} as the suite "
          f"runs them, above; {BASELINE} without a switch is the study's):",
          "", f"| scene | seeds | {METHOD} | {BASELINE}, no switch | {BASELINE}, as the suite "
          "runs it | Δ against no switch | Δ against the suite's |", "|---|---|---|---|---|---|---|",
          *lines, "",
          f"Over {len(table)} scene{'s' * (len(table) > 1)}: Δ {both[:, 0].mean():+.2f} dB "
          f"against {BASELINE} without the switch, {both[:, 1].mean():+.2f} dB against the suite's. Per "
          "kind: " + "; ".join(
              f"{k} {np.mean([d for d, _ in v]):+.2f} / {np.mean([e for _, e in v]):+.2f} "
              f"({len(v)})" for k, v in sorted(kinds.items())) + ". The switch as the "
          "baseline's default, by the rule (docs/validation.md) per scene geometry: "
          + "; ".join(f"{k}: {v}" for k, v in sorted(verdicts.items())) + "." + now, ""]
