"""HALO's margin at the largest budget against the baseline given the same
chance: nerf_tuned with twice its samples once it has trained as long as
HALO's Hi before its sampler switch (budget_studies.BASELINE_TWIN, run in
the `hi_window` study on validation views). Tells HALO's gain from the
switch apart from any NeRF's gain from more samples late."""
import numpy as np

from experiments.bench import budget_studies, code_version, default_rule, study_records
from experiments.bench.report_common import BASELINE

METHOD = "halo"


def rows(runs, twins) -> list:
  """[(scene, seeds, halo, nerf_tuned, twin)]: the mean PSNR of each over the
  seeds all three ran, for every scene of `runs` ({scene: {method: [record]}},
  the budget suite's) that `twins` ({scene: [record]}) covers."""
  out = []
  for scene, by in runs.items():
    if scene not in twins:
      continue
    mine = {m: {r["seed"]: r["psnr"] for r in by.get(m, [])} for m in (METHOD, BASELINE)}
    twin = {r["seed"]: r["psnr"] for r in twins.get(scene, [])}
    seeds = sorted(set(twin) & set(mine[METHOD]) & set(mine[BASELINE]))
    if seeds:
      out.append((scene, seeds, *(float(np.mean([d[k] for k in seeds]))
                                  for d in (mine[METHOD], mine[BASELINE], twin))))
  return out


def section(runs, results: str, budget_s: float) -> list:
  """The budget page's lines on HALO's margin at equal chance at `budget_s`
  ([] before any twin has run): per scene and per kind, halo less
  nerf_tuned and less the twin, and whether the twin passes the default
  rule as the baseline's default on each scene kind."""
  name = f"hi_window_{budget_s:g}"
  recs = study_records.read(results, name)
  twins = {s: rs for (s, v), rs in recs.items() if v == budget_studies.BASELINE_TWIN}
  table = rows(runs, twins)
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
                                      reference=BASELINE, scenes=s)
              for k, s in default_rule.by_kind(study, recs).items()}
  both = np.asarray([(h - b, h - t) for _, _, h, b, t in table])
  return [f"### At equal chance: {BASELINE} with the same switch", "",
          f"HALO's Hi takes twice its samples once it has trained "
          f"{budget_studies.SAMPLES_SWITCH} steps. `{budget_studies.BASELINE_TWIN}` gives "
          f"{BASELINE} the same: twice its 64 samples from the same step, trained and scored so "
          f"([the `{name}` study](ablation_{name}.md), the same views and budget). Per scene "
          f"(the seeds all three ran), {METHOD} and {BASELINE} as above:", "",
          f"| scene | seeds | {METHOD} | {BASELINE} | twin | Δ | Δ against the twin |",
          "|---|---|---|---|---|---|---|", *lines, "",
          f"Over {len(table)} scene{'s' * (len(table) > 1)}: Δ {both[:, 0].mean():+.2f} dB against {BASELINE}, "
          f"{both[:, 1].mean():+.2f} dB against the twin. Per kind: " + "; ".join(
              f"{k} {np.mean([d for d, _ in v]):+.2f} / {np.mean([e for _, e in v]):+.2f} "
              f"({len(v)})" for k, v in sorted(kinds.items())) + ". The twin as the "
          "baseline's default, by the rule (docs/validation.md) per scene geometry: "
          + "; ".join(f"{k}: {v}" for k, v in sorted(verdicts.items())) + ".", ""]
