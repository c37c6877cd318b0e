"""The rule a variant must pass to become a default (docs/validation.md),
applied to a study's records (experiments/bench/ablations.py)."""
import os
import statistics

import ml_collections

from experiments.bench import budget_studies, identity, study_records
from experiments.bench.studies import STUDIES, Study
from halo_jax import datasets

def pairs(study: Study, recs, variant: str, reference: str = "") -> list:
  """[(record, reference record), ...]: `variant`'s runs beside the run of
  the same scene and seed of `reference` (the study's, unless named), over
  every pair both ran."""
  out = []
  for scene in study.scenes:
    ref = {r["seed"]: r for r in recs.get((scene.name, reference or study.reference), [])}
    out += [(r, ref[r["seed"]]) for r in recs.get((scene.name, variant), []) if r["seed"] in ref]
  return out




# The rule a default's change must pass (docs/validation.md): measured on at
# least MIN_SEEDS seeds of every scene of the kind it applies to, it may lose
# no more than MAX_LOSS_DB (mean over seeds) on any of them.
MIN_SEEDS, MAX_LOSS_DB = 2, 0.3


IDENTICAL = "identical"


def verdict(study: Study, recs, variant: str, identical=None, reference: str = "",
                 scenes=None) -> str:
  """Whether `variant` may replace `reference` (the study's, unless named)
  as the default over `scenes` (the study's, unless named)
  (docs/validation.md): with MIN_SEEDS seeds on every scene, its mean loses
  no more than MAX_LOSS_DB on any scene, and the mean over scenes (each
  weighs the same) is a gain. 'passes', 'fails: <scenes and their mean Δ>',
  'fails: no gain on the mean (<Δ>)' or 'not measured: <scenes short of
  seeds>'; or, where `identical` ({scene: bool}, identity.py's fingerprint
  runs at the study's budget) holds on every scene, 'identical: ...': the
  variant is the reference here, and is judged at the budgets where it
  differs (judged_across)."""
  scenes = study.scenes if scenes is None else scenes
  if identical and all(identical.get(s.name) for s in scenes):
    return (f"{IDENTICAL}: the reference to the last digit at {study.budget_s:g} s "
            "(fingerprint runs on every scene), judged where it differs")
  by_scene = {}
  for r, ref in pairs(study, recs, variant, reference):
    by_scene.setdefault(r["scene"], []).append(r["psnr"] - ref["psnr"])
  short, losses, means = [], [], []
  for scene in scenes:
    deltas = by_scene.get(scene.name, [])
    if len(deltas) < MIN_SEEDS:
      short.append(scene.name)
      continue
    means.append(statistics.mean(deltas))
    if means[-1] < -MAX_LOSS_DB:
      losses.append(f"{scene.name} {means[-1]:+.2f}")
  if losses:
    return "fails: " + ", ".join(losses)
  if short:
    return "not measured: " + ", ".join(short)
  if statistics.mean(means) <= 0:
    return f"fails: no gain on the mean ({statistics.mean(means):+.2f} dB)"
  return "passes"


def judged_across(verdicts: dict) -> str:
  """A variant's verdict over the budgets of its family ({budget_s: its
  verdict there}): judged at the budgets where it differs from
  the reference, and only there. 'fails at B s: ...' where it fails at one;
  else 'not measured at B s' where one lacks runs; else 'passes at B s
  (identical at C s)'; 'not measured: identical at every budget' when no
  budget sets it apart."""
  differs = {b: v for b, v in sorted(verdicts.items()) if not v.startswith(IDENTICAL)}
  same = [b for b, v in sorted(verdicts.items()) if v.startswith(IDENTICAL)]
  at = lambda bs: ", ".join(f"{b:g}" for b in bs) + " s"  # noqa: E731
  if not differs:
    return "not measured: identical at every budget"
  failed = [f"at {b:g} s: {v[len('fails: '):]}" for b, v in differs.items()
            if v.startswith("fails")]
  if failed:
    return "fails " + "; ".join(failed)
  short = [b for b, v in differs.items() if v != "passes"]
  if short:
    return f"not measured at {at(short)}"
  return f"passes at {at(differs)}" + (f" (identical at {at(same)})" if same else "")


def _family_verdicts(study_name: str, variant: str, results: str, reference: str) -> dict:
  """{budget_s: verdict} of `variant` against `reference` in
  each study of `study_name`'s family that has it ({} for a study of one
  budget)."""
  out = {}
  for b, name in budget_studies.family_of(study_name).items():
    other = STUDIES[name]
    if any(v.name == variant for v in other.variants):
      out[b] = verdict(other, study_records.read(results, name), variant,
                            identity.read(name, os.path.join(results, "identity")).get(variant),
                            reference)
  return out


def _judged(study: Study) -> list:
  """[(variant, the variant it may replace)]: each variant against the one
  it is checked against (identity.reference_of: the variant it names, else
  the study's reference for its method's variants and the variant named
  after another method for that method's; a baseline's same chance is
  judged as the baseline's default)."""
  out = []
  for v in study.variants:
    ref = identity.reference_of(study, v)
    if ref is not None and ref is not v:
      out.append((v.name, ref.name))
  return out


def by_kind(study: Study, recs) -> dict:
  """{scene kind: [scene, ...]} of the study's scenes that have records with
  a resolved config: the geometry a method's recipe is chosen by
  (halo_jax.datasets.scene_kind), so a default may differ by it."""
  out = {}
  for scene in study.scenes:
    data = next((r["resolved_config"]["data"] for (s, _), rr in sorted(recs.items())
                 if s == scene.name for r in rr if "data" in r.get("resolved_config", {})), None)
    if data is not None:
      out.setdefault(datasets.scene_kind(ml_collections.ConfigDict(data)), []).append(scene)
  return out


def lines(study_name: str, study: Study, recs, results: str) -> list:
  """The study page's section on the rule: each judged variant's verdict
  here, per scene kind, and over its budget family."""
  same = identity.read(study_name, os.path.join(results, "identity"))
  judged = _judged(study)
  if not judged:
    return []
  family = budget_studies.family_of(study_name)
  kinds = by_kind(study, recs)
  rows = []
  for name, ref in judged:
    here = verdict(study, recs, name, same.get(name), ref)
    across = judged_across(_family_verdicts(study_name, name, results, ref)) if family else ""
    per_kind = "; ".join(f"{k}: {verdict(study, recs, name, same.get(name), ref, s)}"
                         for k, s in sorted(kinds.items()))
    rows.append(f"| `{name}` | `{ref}` | {here} |" + (f" {per_kind} |" if len(kinds) > 1 else "")
                + (f" {across} |" if family else ""))
  return ["", "## Against the default rule", "",
          f"A variant may replace the default it changes (`{study.reference}`, its own "
          f"method's unchanged variant, or the variant it adds to: `against`) only if, on at least {MIN_SEEDS} seeds of "
          f"every scene of the study, its mean loss on no scene exceeds {MAX_LOSS_DB} dB "
          "and its mean over the scenes (each weighs the same) is a gain "
          "(docs/validation.md)." + (
              " Where the study spans scene kinds, the rule is also applied to each kind's "
              "scenes alone (a default may differ by kind)." if len(kinds) > 1 else "") + (
              " A variant that fingerprint runs show to be the reference to the last digit at "
              f"this budget (`python -m experiments.same_numbers --study={study_name}`) is "
              "judged at the budgets where it differs" + (
                  " (the last column: this question at " + ", ".join(f"{b:g}" for b in family)
                  + " s)" if family else "") + "." if study.budget == "time" else ""), "",
          "| variant | against | verdict |" + (" per kind |" if len(kinds) > 1 else "")
          + (" over the budgets |" if family else ""),
          "|---|---|---|" + ("---|" if len(kinds) > 1 else "") + ("---|" if family else "")] + rows
