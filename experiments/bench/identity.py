"""Whether a study's variant trains and scores bit-identically to its
reference at the study's budget, shown by fingerprint runs, not by training
the study: a change that only acts after some step (a switch past the steps
a stage trains at a short budget) need only be judged where it acts.

The check runs, on each scene of a time study, the fingerprint run
(fingerprint.py) of the reference and of each variant of its method, on the
study's terms with their own overrides, and compares every figure it hashes. The
fingerprint run trains each stage past every step switch (fingerprint.
SWITCHES) that the study's run of it crosses at the budget, so a switch the
budget crosses is crossed there too and shows. Equal figures on every scene:
the variant is the reference at that budget.

  python -m experiments.same_numbers --study=NAME --out=/tmp/NAME.json [--procs=2]

writes results/identity/<study>.json: {"study", "budget_s", "variants":
{variant: {scene: true|false}}, "provenance"}, which the study's rule reads.
"""
import json
import os

from experiments.bench import git_state, run_file
from experiments.bench.paths import REPO

ROOT = os.path.join(REPO, "results", "identity")


def path(study_name: str, root: str = ROOT) -> str:
  return os.path.join(root, f"{study_name}.json")


def read(study_name: str, root: str = ROOT) -> dict:
  """{variant: {scene: bool}} of a study's identity file ({} when none)."""
  p = path(study_name, root)
  if not os.path.exists(p):
    return {}
  with open(p) as f:
    return json.load(f).get("variants", {})


def runs(study, names=()) -> list:
  """[(scene, variant), ...]: the fingerprint runs the check needs, the
  reference and every other variant of its method (those in `names`, when
  given) on each scene."""
  ref = next(v for v in study.variants if v.name == study.reference)
  others = [v for v in study.variants if v.method == ref.method and v.name != ref.name
            and (not names or v.name in names)]
  unknown = set(names) - {v.name for v in others}
  if unknown:
    raise ValueError(f"{', '.join(sorted(unknown))}: not a variant of the study's method "
                     f"beside its reference {study.reference!r}")
  return [(scene, v) for scene in study.scenes for v in (ref, *others)]


def verdicts(study, figures: dict) -> dict:
  """{variant: {scene: identical}} from fingerprint figures keyed
  'scene/variant' (scenes whose reference or variant run is missing are
  left out)."""
  out = {}
  for scene, v in runs(study):
    ref, got = figures.get(f"{scene.name}/{study.reference}"), figures.get(f"{scene.name}/{v.name}")
    if v.name != study.reference and ref is not None and got is not None:
      out.setdefault(v.name, {})[scene.name] = got == ref
  return out


def write(study_name: str, budget_s: float, found: dict, root: str = ROOT) -> str:
  """Merges `found` ({variant: {scene: bool}}) into the study's file;
  returns its path."""
  p = path(study_name, root)
  old = read(study_name, root)
  for v, scenes in found.items():
    old.setdefault(v, {}).update(scenes)
  run_file.write_json(p, git_state.stamp({"study": study_name, "budget_s": budget_s,
                                          "variants": old}))
  return p
