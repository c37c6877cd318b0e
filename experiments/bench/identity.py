"""Whether a study's variant trains and scores bit-identically to its
reference at the study's budget, shown by fingerprint runs, not by training
the study: a change that only acts after some step (a switch past the steps
a stage trains at a short budget) need only be judged where it acts.

The check runs, on each scene of a time study, the fingerprint run
(fingerprint.py) of each variant and of what it is checked against (the
study's reference for a variant of its method, the plain method for the
baseline's twins), on the study's terms with their own overrides, and
compares every figure it hashes. The
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
import time

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


def reference_of(study, variant):
  """The variant `variant` is checked against: the one it names
  (`against`); else the study's reference for a variant of its method, and
  for another method's the variant named after that method; None where the
  study has none."""
  if variant.against:
    return next(v for v in study.variants if v.name == variant.against)
  ref = next(v for v in study.variants if v.name == study.reference)
  if variant.method == ref.method:
    return ref
  return next((v for v in study.variants if v.name == variant.method), None)


def runs(study, names=()) -> list:
  """[(scene, variant), ...]: the fingerprint runs the check needs: each
  variant (those in `names`, when given) that has a reference to be checked
  against (reference_of), and that reference, on each scene."""
  refs = {v.name for v in study.variants if reference_of(study, v) is v}
  checked = [v for v in study.variants if v.name not in refs and reference_of(study, v)
             and (not names or v.name in names)]
  unknown = set(names) - {v.name for v in checked}
  if unknown:
    raise ValueError(f"{', '.join(sorted(unknown))}: not a variant the study can check "
                     f"against {study.reference!r} or its method as it is")
  wanted = {reference_of(study, v).name for v in checked} | {v.name for v in checked}
  return [(scene, v) for scene in study.scenes for v in study.variants if v.name in wanted]


def verdicts(study, figures: dict) -> dict:
  """{variant: {scene: identical}} from fingerprint figures keyed
  'scene/variant', each variant against its reference (reference_of; pairs
  with a run missing are left out)."""
  out = {}
  for scene in study.scenes:
    for v in study.variants:
      ref = reference_of(study, v)
      if ref is None or ref is v:
        continue
      theirs, ours = (figures.get(f"{scene.name}/{x.name}") for x in (ref, v))
      if theirs is not None and ours is not None:
        out.setdefault(v.name, {})[scene.name] = ours == theirs
  return out


def write(study_name: str, budget_s: float, found: dict, root: str = ROOT, git=None) -> str:
  """Merges `found` ({variant: {scene: bool}}) into the study's file, with
  the git state of the code that ran the fingerprints (`git`, taken when
  they started; by default the checkout's now); returns its path."""
  p = path(study_name, root)
  old = read(study_name, root)
  for v, scenes in found.items():
    old.setdefault(v, {}).update(scenes)
  run_file.write_json(p, {"study": study_name, "budget_s": budget_s, "variants": old,
                          "provenance": {"git": git or git_state.git_state(),
                                         "time_utc": time.strftime("%Y-%m-%dT%H:%M:%SZ",
                                                                   time.gmtime())}})
  return p
