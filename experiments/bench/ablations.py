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

  python -m experiments.ablations --study=dnerf_hi [--only=REGEX] [--core=0|1]
  python -m experiments.ablations --study=fog --dry_run
  python -m experiments.ablations --study=fog --report_only

A variant whose resolved config is that of a finished suite run (a method
without overrides on the validation suite's terms) adopts that run's record
instead of training it again (`adopted_from` names it).

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

from absl import flags, logging

from experiments.bench import (adopt, benchmark, code_version, default_rule,
                               fronts_report, gap_report, git_state, report_common, rescore,
                               run_file, selection, study_records, suites, tool)
from experiments.bench.paths import REPO
from experiments.bench.studies import MATCHED_STEPS, STUDIES, Study, Variant  # noqa: F401
from halo_jax import frozen, progress, protocol, runs
from halo_jax.configure import finish

FLAGS = flags.FLAGS


def terms(study: Study) -> suites.Suite:
  """The CPU suite's terms (at the study's own budget, with the curve of the
  budget study's suite of it) on the study's scenes' validation views."""
  terms = suites.CPU
  if study.budget_s and study.budget_s != suites.CPU.budget_s:
    same = [suites.SUITES[n] for n, s in suites.BUDGET_STUDY.items() if s == study.budget_s]
    terms = dataclasses.replace(terms, budget_s=study.budget_s,
                                curve_points=same[0].curve_points if same else terms.curve_points)
  return dataclasses.replace(terms, scenes=study.scenes,
                             overrides=suites.CPU.overrides + suites.VALIDATION_VIEWS)


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


def matched_steps(results: str, scene: suites.Scene) -> dict:
  """{stage: steps} a study's run of `scene` stops each stage at
  (MATCHED_STEPS). `results` is unused; kept for the call sites."""
  del results
  if scene.name not in MATCHED_STEPS:
    raise KeyError(f"no matched steps for scene {scene.name!r}: add it to "
                   "experiments/bench/studies.py MATCHED_STEPS")
  return dict(MATCHED_STEPS[scene.name])


def run_overrides(study: Study, variant: Variant) -> tuple:
  """The overrides a study's run of `variant` composes: the variant's, and
  no front where the study scores none."""
  no_front = (("eval.front_s", ()),) if study.budget == "time" and not study.front else ()
  return tuple(variant.overrides) + no_front


def configure(study: Study, scene: suites.Scene, variant: Variant, seed: int, scratch: str,
              results: str):
  c = benchmark.configure(terms(study), scene, variant.method, seed, "budget", scratch,
                          run_overrides(study, variant))
  if study.budget == "time":
    return c
  # equal steps: the suite run's counts as caps on the composed run
  c = frozen.thaw(c)
  caps = {n: max(steps, c[n].min_steps)  # a suite run that trained less than the floor
          for n, steps in matched_steps(results, scene).items()}
  protocol.steps(c, caps)
  for n, steps in caps.items():
    c[n].eval_every = max(1, steps // 2)
  return finish(c)


def _write(record, study_name, scene, variant, seed, c, results, start) -> dict:
  """`record` with what names the study's run (its config `c`, started at
  `start`), written to its result file; returns it."""
  record.pop("per_view", None)
  record.update(study_records.study_fields(study_name, variant, c, record["stages"]),
                scene=scene.name, config=scene.config, method=variant.method, seed=seed,
                run_seconds=round(time.time() - start, 1))
  run_file.write_json(result_path(results, study_name, scene, variant, seed), record)
  return record


def run_one(study_name, study, scene, variant, seed, results, scratch) -> dict:
  c = configure(study, scene, variant, seed, scratch, results)
  workdir = os.path.join(scratch, "ablations", study_name, scene.name, variant.name,
                         f"seed{seed}")
  start = time.time()
  same = adopt.identical_suite_run(c, scene, variant.method, seed, results)
  if same:
    record = dict(same[1], adopted_from=adopt.source(same[0], results))
  else:
    record = git_state.stamp(runs.run_method(c, workdir))
  if study.budget == "time" and study.front:
    record["front"] = benchmark.front_points(workdir, record, with_lpips=False)
  return _write(record, study_name, scene, variant, seed, c, results, start)


def rescore_one(study_name, study, scene, variant, seed, results, scratches) -> dict:
  """The record of a variant that changes only how a run renders
  (rescore.py): the suite run it trains (the variant without those fields),
  scored with its fields; writes it.
  rescore.NotRenderOnly when it cannot be."""
  ref = rescore.as_trained(variant)
  if ref is variant:
    raise rescore.NotRenderOnly("it changes no field of how a run renders")
  c = configure(study, scene, variant, seed, "/tmp/halo_rescore", results)
  rc = configure(study, scene, ref, seed, "/tmp/halo_rescore", results)
  fields = rescore.render_fields(rc, c)
  path, record, workdir = rescore.reference_run(rc, scene, ref.method, seed, results, scratches)
  start = time.time()
  record = rescore.rescored(record, workdir, fields, c.eval.lpips)
  record.pop("adopted_from", None)
  record["rescored_from"] = dict(adopt.source(path, results), workdir=workdir,
                                 fields=[list(f) for f in fields])
  record["provenance"] = dict(record.get("provenance") or {}, rescored_by=git_state.git_state())
  return _write(record, study_name, scene, variant, seed, c, results, start)


def _rescore_all(study, todo):
  for scene, variant, seed in todo:
    tag = f"{scene.name}/{variant.name}/seed{seed}"
    try:
      r = rescore_one(FLAGS.study, study, scene, variant, seed, FLAGS.results,
                      FLAGS.rescore_from)
    except rescore.NotRenderOnly as e:
      print(f"not rescored {tag}: {e}", flush=True)
      continue
    print(f"rescored {tag}: {r['psnr']:.2f} (on {r['rescored_from']['path']})", flush=True)


def _mean_std(xs):
  if not xs:
    return ""
  if len(xs) == 1:
    return f"{xs[0]:.2f}"
  return f"{statistics.mean(xs):.2f} ± {statistics.stdev(xs):.2f}"


def _overall(study: Study, recs) -> list:
  """Lines of a table: per variant, its difference from the reference over
  every (scene, seed) both ran, and how many of those it lost."""
  rows = []
  for v in study.variants:
    if v.name == study.reference:
      continue
    deltas = [r["psnr"] - ref["psnr"] for r, ref in default_rule.pairs(study, recs, v.name)]
    if deltas:
      rows.append(f"| `{v.name}` | {len(deltas)} | {statistics.mean(deltas):+.2f} | "
                  f"{min(deltas):+.2f} | {sum(d < 0 for d in deltas)} |")
  if not rows:
    return []
  return ["", "## Over all scenes and seeds", "",
          f"Each variant against `{study.reference}` over the (scene, seed) pairs both ran.", "",
          "| variant | pairs | mean Δ | worst Δ | pairs lost |", "|---|---|---|---|---|"] + rows


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
    for r, ref in default_rule.pairs(study, recs, v.name):
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
    return (f"CPU suite terms: {terms(study).budget_s:g} s of training on one core"
            + (", each run's state saved at the suite's front times" if study.front else
               ", scored at the end"))
  return ("CPU suite terms at matched steps (each stage stops at the steps the suite's "
          f"{suites.CPU.budget_s:g}-s `halo` runs of the scene reached, its schedules "
          "unchanged)")


def _variant_row(study: Study, v: Variant, rs, ref) -> str:
  """One variant's row of a scene's table, from its records `rs` and the
  reference variant's records by seed `ref`."""
  final = [r["psnr"] for r in rs]
  lo = [r["stages"]["lo"]["psnr"] for r in rs if "psnr" in r["stages"].get("lo", {})]
  drop = [r["psnr"] - r["stages"]["lo"]["psnr"] for r in rs
          if "psnr" in r["stages"].get("lo", {})]
  delta = [r["psnr"] - ref[r["seed"]]["psnr"] for r in rs if r["seed"] in ref]
  steps = f"{statistics.mean(r['wall_s'] for r in rs):.0f}"
  return (f"| `{v.name}` | {len(rs)} | {_mean_std(final)} | {_mean_std(lo)} | "
          f"{f'{statistics.mean(drop):+.2f}' if drop else ''} | "
          f"{f'{statistics.mean(delta):+.2f}' if delta and v.name != study.reference else ''}"
          f" | {steps} |")


def report(study_name: str, study: Study, results: str) -> str:
  """The study's page (markdown), from its result files."""
  recs = study_records.read(results, study_name)
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
      lines.append(_variant_row(study, v, rs, ref))
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
  lines += _overall(study, recs) + gap_report.lines(study, recs)
  lines += default_rule.lines(study_name, study, recs, results)
  lines += [""] + report_common.collapse_lines(
      [(f"{scene}/{variant}/seed{r['seed']}", r) for (scene, variant), rs in sorted(recs.items())
       for r in rs])
  if study.budget == "time" and study.front:
    lines += _overall_fronts(study, recs)
  commits = sorted({(r["provenance"].get("git") or {}).get("commit", "?")[:7]
                    for rs in recs.values() for r in rs})
  if commits:
    lines += ["", f"Commits: {', '.join(commits)}."]
  adopted = sum(1 for rs in recs.values() for r in rs if r.get("adopted_from"))
  if adopted:
    lines += ["", f"{adopted} run(s) are a suite's runs of the same resolved config "
              "(`adopted_from` in the record), not run again."]
  rescored = sum(1 for rs in recs.values() for r in rs if r.get("rescored_from"))
  if rescored:
    lines += ["", f"{rescored} run(s) change only how a trained run renders: each is its "
              "reference's suite run scored again with the variant's fields "
              "(`rescored_from` in the record; experiments/bench/rescore.py), not trained "
              "again; its training figures and curve are the reference's."]
  lines += _fingerprint_lines(study, recs)
  return "\n".join(lines) + "\n"


def _fingerprint_lines(study: Study, recs) -> list:
  """Per variant, the code fingerprints of its method that its runs measure
  (experiments/bench/code_version.py): a variant whose runs span two fingerprints,
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
  """This script's flags, and the runner's (--only, --results, --scratch, --dry_run)."""
  benchmark.define_flags()
  flags.DEFINE_enum("study", "fog", sorted(STUDIES), "Study to run.")
  flags.DEFINE_string("docs", os.path.join(REPO, "docs", "results"), "Report folder.")
  flags.DEFINE_integer("core", -1, "Pin to this one core (-1: the machine's last).")
  flags.DEFINE_bool("report_only", False, "Write the report from the result files only.")
  flags.DEFINE_list("rescore_from", [], "Train nothing: score each variant that changes only "
                    "how a run renders (rescore.RENDER_ONLY) on its reference's suite run, "
                    "whose workdir is under one of these --scratch folders.")


def main(argv):
  del argv
  logging.set_verbosity(logging.WARNING)
  git_state.pin_start()  # the code this process runs, whatever is committed meanwhile
  study = STUDIES[FLAGS.study]
  if not FLAGS.report_only:
    if hasattr(os, "sched_setaffinity"):
      allowed = sorted(os.sched_getaffinity(0))
      os.sched_setaffinity(0, [allowed[FLAGS.core]])
    try:
      todo = _plan(study, FLAGS.only)
    except ValueError as e:
      sys.exit(str(e))
    failed, runnable = [], []
    for scene, variant, seed in todo:
      path = result_path(FLAGS.results, FLAGS.study, scene, variant, seed)
      now = (configure(study, scene, variant, seed, FLAGS.scratch, FLAGS.results)
             if benchmark.has_data(scene) else None)
      state = benchmark._state(  # pylint: disable=protected-access
          path, scene, terms(study), config=now)
      if FLAGS.dry_run or state not in ("to run", "stale config"):
        print(f"{state:8} {scene.name}/{variant.name}/seed{seed}", flush=True)
      else:
        runnable.append((scene, variant, seed))
    if FLAGS.rescore_from:
      _rescore_all(study, runnable)
      runnable = []
    for scene, variant, seed in progress.steps(runnable, "runs", f"study {FLAGS.study}"):
      tag = f"{scene.name}/{variant.name}/seed{seed}"
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


def cli():
  """The tool's entry point (python -m experiments.<tool>)."""
  define_flags()
  tool.run(sys.modules[__name__], main)


if __name__ == "__main__":
  cli()
