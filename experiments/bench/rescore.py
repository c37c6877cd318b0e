"""A study's variant that changes only how a trained run is rendered for
scoring (RENDER_ONLY: the held-out sampler after a step), scored on its
reference's trained run instead of training it again.

Such a variant trains exactly what its reference trains: every field that
training reads is the reference's (checked on the composed configs, with
no stage selecting its parameters on held-out renders). So its run is the
reference's finished run (a suite's record of the same resolved config,
whose workdir is still on this machine) rendered on the same views with the
variant's fields. The record copies the reference's (its training figures,
curve and seconds are the reference's: the curve's renders were the
reference's sampler) with the final stage's scores replaced, and names its
source in `rescored_from` (the record's path, sha256 and commit, and the
workdir).

  python -m experiments.ablations --study=hi_window_960 --rescore_from=/tmp/a,/tmp/b
"""
import dataclasses
import json
import os
import tempfile

from halo_jax import config_files, protocol
from halo_jax.stages.order import needed
from experiments.bench import adopt, paths

# Stage fields that change how a trained stage renders its held-out views,
# and nothing that training reads.
RENDER_ONLY = ("sampler.dense_eval_after", "sampler.dense_eval_samples")


def as_trained(variant):
  """The variant whose trained run `variant` renders: its RENDER_ONLY
  overrides replaced by no dense renders in each stage they set (itself
  where it has none)."""
  render = [o for o in variant.overrides if any(o[0].endswith("." + f) for f in RENDER_ONLY)]
  if not render:
    return variant
  stages = sorted({o[0].split(".sampler.")[0] for o in render})
  kept = tuple(o for o in variant.overrides if o not in render)
  return dataclasses.replace(variant, name=f"{variant.name} as trained", overrides=kept + tuple(
      (f"{n}.sampler.dense_eval_after", 0) for n in stages))


class NotRenderOnly(ValueError):
  """The variant changes what trains, or its reference's run is not here."""


def render_fields(ref_config, config) -> tuple:
  """((dotted field, value), ...) where `config` differs from `ref_config`
  (both composed), all of them RENDER_ONLY fields of a stage; NotRenderOnly
  naming the others, or a stage that selects its parameters on held-out
  renders (which would make them train-time fields)."""
  a, b = (config_files.dotted_fields(protocol.applied(json.loads(c.to_json_best_effort())))
          for c in (ref_config, config))
  stages = needed(config, config.final_stage)
  moved = sorted(k for k in set(a) | set(b) if a.get(k) != b.get(k))
  render = {f"{n}.{f}" for n in stages for f in RENDER_ONLY}
  other = [k for k in moved if k not in render and k != "data.root"]
  if other:
    raise NotRenderOnly(f"changes what trains: {', '.join(other)}")
  if any(config[n].get("select_best", False) for n in stages):
    raise NotRenderOnly("a stage selects its parameters on held-out renders (select_best)")
  return tuple((k, b[k]) for k in moved if k in render)


def reference_run(ref_config, scene, method, seed, results, scratches):
  """(record path, record, workdir): a finished suite run of `ref_config`
  (adopt.same_config_runs) whose workdir, under one of `scratches` (the
  suites' --scratch folders), holds its finished final stage trained with
  that config; NotRenderOnly when there is none."""
  runs = adopt.same_config_runs(ref_config, scene, method, seed, results)
  if not runs:
    raise NotRenderOnly(f"no suite run of {scene.name}/{method}/seed{seed} has the "
                        "reference's config")
  for path, record in runs:
    places = (w for scratch in scratches
              for w in paths.workdirs_of(scratch, record, "budget", scene, method, seed))
    for workdir in places:
      stored = os.path.join(workdir, ref_config.final_stage, "final", "config.json")
      if os.path.exists(stored) and _trained_as(stored, record):
        return path, record, workdir
  raise NotRenderOnly(f"{scene.name}/{method}/seed{seed}: no workdir of its suite run under "
                      f"{', '.join(scratches)}")


def _trained_as(stored_path: str, record: dict) -> bool:
  """Whether the workdir's stored config is the record's, as trained (a
  field added since the record counting as adopt's rule counts it)."""
  with open(stored_path) as f:
    stored = json.load(f)
  return adopt.same_resolved(stored, record["resolved_config"])


# The reference scored again as it was trained must give its record's PSNR
# within this (the same renders; the last bits of a sum over views).
SAME_DB = 1e-3


def _scored(workdir, stage, with_lpips, fields=()):
  """evaluate.run_evaluation's scores of the run's own held-out views (its
  config's test split and views, as training scored them)."""
  from halo_jax.cli import evaluate as evaluation  # pylint: disable=import-outside-toplevel
  with tempfile.TemporaryDirectory(prefix="rescore_") as out:
    return evaluation.run_evaluation(workdir, stage, "test", "", out=out,
                                     with_lpips=with_lpips, render_overrides=fields)


def rescored(record: dict, workdir: str, fields, with_lpips: bool) -> dict:
  """`record` (the reference's) with its final stage scored again on the
  views it was scored on, rendered with `fields` laid over its stored config.
  First the workdir is scored as it was trained: NotRenderOnly unless that
  gives the record's PSNR (within SAME_DB), so the workdir is the record's run."""
  final = list(record["stages"])[-1]
  again = _scored(workdir, final, False)["float"]["psnr"]
  if abs(again - record["psnr"]) > SAME_DB:
    raise NotRenderOnly(f"{workdir}: scored as trained it gives {again:.4f} dB, its record "
                        f"{record['psnr']:.4f}: not the record's run")
  r = _scored(workdir, final, with_lpips, fields)
  scores = r["float"]
  new = dict(record)
  new.update(psnr=scores["psnr"], ssim=scores["ssim"], lpips=scores.get("lpips"),
             num_views=r["num_views"])
  new["stages"] = dict(record["stages"], **{final: dict(record["stages"][final],
                                                         psnr=scores["psnr"])})
  new["per_view"] = r["float"]["per_view"]
  new.pop("validation", None)  # the suite's own scoring of its views, of the reference
  return new
