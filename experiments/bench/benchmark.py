"""Runs a benchmark suite (experiments/bench/suites.py): every scene x method x seed.

  python -m experiments.benchmark --suite=cpu [--mode=budget|steps] [--only=REGEX]
  python -m experiments.benchmark --suite=cpu --dry_run      # the plan and what is done

Mode 'budget' gives every method the suite's budget_s reference seconds (the
'budget' protocol, halo_jax/protocol.py: split over a method's stages by
config.budget_shares, each share a step count from the committed step table,
so a run trains the same steps on any machine); mode 'steps' gives
every method the suite's number of training steps, split the same way.
Each finished run writes one small JSON file,
  results/<suite>/<mode>/<scene>/<method>/seed<k>.json
(per-view PSNR / SSIM / LPIPS, the held-out curve against seconds, steps,
provenance; on scenes with a validation split, each stage's PSNR on all of
its views, scored after training), which is committed: a run whose file
exists is skipped (unless its resolved config is not the one the suite
composes now: 'stale config', rerun), so a
suite resumes across machines from the repository. A run killed part way
resumes from its checkpoints in --scratch on the same machine. Runs go seed
by seed (every scene and method at seed 0 first), so a partial suite covers
every scene. experiments/report.py turns the files into docs/results/.
"""
import json
import os
import sys
import time
import traceback

from absl import flags, logging

from experiments.bench import git_state, run_file, selection, suites, tool
from experiments.bench.paths import REPO, result_path, workdir_of  # the last two re-exported
from halo_jax import defaults, progress, protocol, runs
from halo_jax.configure import compose
from halo_jax.stages import collapse

FLAGS = flags.FLAGS


def define_flags():
  """The runner's flags (ablations and step_times reuse --results, --scratch,
  --only and --dry_run): defined by the entry point, not on import, so that a
  module that only configures runs (code_version) adds no flags."""
  flags.DEFINE_enum("suite", "cpu", sorted(suites.SUITES), "Suite to run.")
  flags.DEFINE_enum("mode", "budget", ["budget", "steps"],
                    "Equal reference seconds (protocol 'budget') or equal steps.")
  flags.DEFINE_string("results", os.path.join(REPO, "results"), "Result files' root.")
  flags.DEFINE_string("scratch", "/tmp/halo_bench", "Workdirs (checkpoints, renders).")
  flags.DEFINE_string("only", "", "Run only runs whose 'scene/method/seed<k>' matches this regex.")
  flags.DEFINE_integer("max_runs", 0, "Stop after this many runs (0: all).")
  flags.DEFINE_bool("dry_run", False, "Print the plan and each run's state; train nothing.")
  flags.DEFINE_bool("score_validation", False, "Train nothing: add the validation scores to "
                    "finished runs' files that lack them, from their workdirs in --scratch.")
  flags.DEFINE_bool("judge_heldout", False, "Train nothing: add the held-out verdict (a stage "
                    "no better than a constant image) to finished runs' files that lack it.")
  flags.DEFINE_bool("add_fronts", False, "Rerun finished runs whose file has no front although "
                    "the suite records one (files from before fronts); the new file replaces it.")
  flags.DEFINE_integer("first_core", -1, "With a suite pinned to k cores: the first of them "
                       "(-1: the machine's last k), e.g. to run two suites side by side.")


def data_root() -> str:
  return defaults.data_root()


def plan(suite: suites.Suite, only: str = ""):
  """[(scene, method, seed), ...] seed-major, filtered by the regex `only`
  (ValueError when it is not one, or selects nothing)."""
  runs = [(scene, m, seed) for seed in range(max(s.seeds for s in suite.scenes))
          for scene in suite.scenes if seed < scene.seeds for m in scene.methods]
  return selection.select(runs, lambda r: f"{r[0].name}/{r[1]}/seed{r[2]}", only,
                          part="method", plan="suite")


def configure(suite: suites.Suite, scene: suites.Scene, method: str, seed: int, mode: str,
              scratch: str, overrides=()):
  """The run's frozen config (configure.compose): the scene's config as
  `method`, this seed and mode, the suite's, the scene's and then
  `overrides`' fields ((dotted field, value) pairs: a study's variant)."""
  from halo_jax import pipeline
  if mode not in ("budget", "steps"):
    raise ValueError(f"mode={mode!r}: must be 'budget' or 'steps'")
  proto = suite.budget_s if mode == "budget" else "steps"
  fields = {"seed": seed, "eval.front_s": tuple(suite.front_s),
            **dict(suite.overrides + scene.overrides + tuple(overrides))}
  first = compose(scene.config, method, fields, protocol=proto)  # its stages and data
  if first.data.kind == "procedural" and not first.data.root:  # generated once, shared by runs
    fields["data.root"] = os.path.join(
        scratch, "scenes", f"{first.data.procedural_scene}_{first.data.procedural_size}")
  names = pipeline.needed(first, first.final_stage)
  if mode == "budget":
    for n in names:  # on the reference clock: the same steps on any machine
      fields[f"{n}.eval_every_s"] = suite.budget_s / suite.curve_points
  else:
    parts = protocol.split(first, suite.steps, names)
    for n in names:
      fields[f"{n}.steps"] = max(1, round(parts[n]))
      # the curve's points evenly spread over the method's steps
      fields[f"{n}.eval_every"] = max(1, int(suite.steps / suite.curve_points))
  return compose(scene.config, method, fields, protocol=proto)


def score_validation(workdir: str, record: dict, split: str) -> dict:
  """Every stage of a finished run that renders (those with a held-out PSNR
  in `record['stages']`) scored on all views of `split`, after training, so
  it costs no training time: {'split', 'num_views', 'stages': {name: {'psnr',
  'ssim'}}}. PSNR and SSIM as training's own evaluation scores them."""
  from halo_jax.cli import evaluate as evaluation
  stages, num_views = {}, 0
  for name, stage in record["stages"].items():
    if "psnr" not in stage:
      continue
    r = evaluation.run_evaluation(workdir, name, split, "all", with_lpips=False)
    margin = record["resolved_config"][name]["collapse"]["margin_db"]
    stages[name] = {**{k: r["float"][k] for k in ("psnr", "ssim")},
                    "learned": collapse.heldout(r["float"]["psnr"], r["constant_psnr"],
                                                margin)["verdict"]}
    num_views = r["num_views"]
  return {"split": split, "num_views": num_views, "stages": stages}


def front_points(workdir: str, record: dict, with_lpips: bool) -> list:
  """The run's error-against-time front on all its held-out views
  (experiments/bench/front_scores.py), ending with its final state's scores."""
  from experiments.bench import front_scores as front
  last = list(record["stages"])[-1]
  final = {"at_s": round(record.get("reference_s") or record["wall_s"], 3),
           "wall_s": record["wall_s"], "stage": last,
           "step": record["stages"][last]["step"], "final": True,
           **{k: record[k] for k in ("psnr", "ssim", "lpips") if record.get(k) is not None}}
  points = front.evaluate_front(workdir, with_lpips)
  if not points:
    raise RuntimeError(f"{workdir} has no snapshots to score: it was trained before the suite "
                       "recorded fronts; remove it (or pass another --scratch) to rerun it")
  return points + [final]


def run_one(suite_name, suite, scene, method, seed, mode, results, scratch) -> dict:
  """Trains one run (resuming its workdir), scores its stages on the scene's
  validation split if it has one, and writes its result file."""
  c = configure(suite, scene, method, seed, mode, scratch)
  workdir = workdir_of(scratch, suite_name, mode, scene, method, seed)
  start = time.time()
  record = _study_run(c, scene, method, seed, mode, results)
  if record is None:
    record = git_state.stamp(runs.run_method(c, workdir))
    if c.eval.front_s:
      record["front"] = front_points(workdir, record, c.eval.lpips)
    if scene.validation:
      record["validation"] = score_validation(workdir, record, scene.validation)
  record.update(suite=suite_name, scene=scene.name, config=scene.config, method=method,
                scene_overrides=[list(o) for o in scene.overrides],
                seed=seed, mode=mode, budget_s=c.budget_s,
                target_steps=suite.steps if mode == "steps" else None,
                run_seconds=round(time.time() - start, 1))
  path = result_path(results, suite_name, mode, scene, method, seed)
  run_file.write_json(path, record)
  return record


def _study_run(c, scene, method, seed, mode, results):
  """A study's run of this suite run's resolved config, made by code that
  computes what this code does (adopt.identical_study_run), as the suite's
  record with `adopted_from`; or None where there is none, or where it lacks
  a figure the suite's record holds (fronts, or validation scores it cannot
  give without its workdir): that run is trained."""
  from experiments.bench import (  # pylint: disable=import-outside-toplevel  (they read runs)
      adopt, study_records)
  same = adopt.identical_study_run(c, scene, method, seed, results) if mode == "budget" else None
  if same is None or (c.eval.front_s and not same[1].get("front")):
    return None
  record = {k: v for k, v in same[1].items() if k not in study_records.FIELDS}
  if scene.validation:
    record["validation"] = adopt.validation_from(record, scene.validation)
    if record["validation"] is None:
      return None
  return dict(record, adopted_from=adopt.source(same[0], results))


def _fill(path, field, fill, done) -> str:
  """Adds `field` to a finished run's file that lacks it: record[field] =
  fill(record), or the word fill returns instead of a value (the run lacks
  what it needs); returns what it did, in a word or two (`done` for added)."""
  if not os.path.exists(path):
    return "nothing"
  with open(path) as f:
    record = json.load(f)
  if field in record:
    return "has it"
  value = fill(record)
  if isinstance(value, str):
    return value
  record[field] = value
  run_file.write_json(path, record)
  return done


def add_validation(suite_name, scene, method, seed, mode, results, scratch) -> str:
  """Adds the validation scores to a finished run's file that lacks them,
  from its workdir."""
  if not scene.validation:
    return "nothing"
  workdir = workdir_of(scratch, suite_name, mode, scene, method, seed)
  return _fill(result_path(results, suite_name, mode, scene, method, seed), "validation",
               lambda r: (score_validation(workdir, r, scene.validation)
                          if os.path.isdir(workdir) else "no workdir"), "scored")


def judge_heldout(suite_name, scene, method, seed, mode, results, scratch) -> str:
  """Adds the held-out verdict (stages/collapse.py: heldout) to a finished
  run's file made before runs carried it: each rendering stage's held-out
  PSNR in the record against the best constant image of the same views,
  loaded as the run loaded them. Nothing is rendered."""
  def verdicts(record):
    from halo_jax import datasets
    c = configure(suites.SUITES[suite_name], scene, method, seed, mode, scratch)
    constant = collapse.constant_psnr(datasets.load(c.data, "").test.images)
    return {n: collapse.heldout(s["psnr"], constant, c[n].collapse.margin_db)["verdict"]
            for n, s in record["stages"].items() if "psnr" in s}
  return _fill(result_path(results, suite_name, mode, scene, method, seed), "heldout_learned",
               verdicts, "judged")


def _state(path, scene, suite, add_fronts=False, config=None):
  """What a run's file says of it: 'done', 'to run', 'no data', 'no front'
  (add_fronts), or 'stale config' where `config` (the run composed now) is
  given and the file's run was trained with another resolved config: a
  default changed where the code fingerprint cannot see it (past every step
  switch its short run crosses), so its figures are not this config's."""
  if os.path.exists(path):
    with open(path) as f:
      record = json.load(f)
    if add_fronts and suite.front_s and not record.get("front"):
      return "no front" if has_data(scene) else "no data"
    if config is not None and not _same_config(config, record):
      return "stale config"
    return "done"
  return "to run" if has_data(scene) else "no data"


def _same_config(config, record) -> bool:
  """Whether a record's run is `config`'s: its resolved config, with the
  render fields a rescored record was scored with (rescore.py) laid over.
  A record older than resolved configs in records cannot be compared, and
  stands (its code's fingerprint is what vouches for it)."""
  from experiments.bench import adopt  # pylint: disable=import-outside-toplevel  (it reads runs)
  if "resolved_config" not in record:
    return True
  return adopt.same_resolved(json.loads(config.to_json_best_effort()), adopt.run_config(record))



def has_data(scene) -> bool:
  """Whether the scene's data folder is here (a built-in scene always is)."""
  return not scene.needs or os.path.isdir(os.path.join(data_root(), scene.needs))


def main(argv):
  del argv
  logging.set_verbosity(logging.WARNING)
  git_state.pin_start()  # the code this process runs, whatever is committed meanwhile
  suite = suites.SUITES[FLAGS.suite]
  if suite.cores and hasattr(os, "sched_setaffinity"):
    # Before JAX starts its thread pool: the same cores for every run.
    allowed = sorted(os.sched_getaffinity(0))
    first = FLAGS.first_core if FLAGS.first_core >= 0 else len(allowed) - suite.cores
    cores = allowed[first:first + suite.cores]
    os.sched_setaffinity(0, cores)
  try:
    todo = plan(suite, FLAGS.only)
  except ValueError as e:
    sys.exit(str(e))
  fill = (judge_heldout if FLAGS.judge_heldout
          else add_validation if FLAGS.score_validation else None)
  if fill:  # train nothing: add a field to finished runs' files
    for scene, method, seed in todo:
      what = fill(FLAGS.suite, scene, method, seed, FLAGS.mode, FLAGS.results, FLAGS.scratch)
      print(f"{what:10} {scene.name}/{method}/seed{seed}", flush=True)
    return
  failed, runnable = [], []
  for scene, method, seed in todo:
    path = result_path(FLAGS.results, FLAGS.suite, FLAGS.mode, scene, method, seed)
    now = (configure(suite, scene, method, seed, FLAGS.mode, FLAGS.scratch)
           if has_data(scene) else None)
    state = _state(path, scene, suite, FLAGS.add_fronts, now)
    if FLAGS.dry_run or state not in ("to run", "no front", "stale config"):
      print(f"{state:8} {scene.name}/{method}/seed{seed}", flush=True)
    else:
      runnable.append((scene, method, seed))
  if FLAGS.max_runs:
    runnable = runnable[:FLAGS.max_runs]
  for scene, method, seed in progress.steps(runnable, "runs", f"suite {FLAGS.suite}"):
    tag = f"{scene.name}/{method}/seed{seed}"
    try:
      r = run_one(FLAGS.suite, suite, scene, method, seed, FLAGS.mode, FLAGS.results,
                  FLAGS.scratch)
    except Exception:  # pylint: disable=broad-except
      # One broken run does not stop the suite; the suite's exit status says so.
      traceback.print_exc()
      print(f"FAILED   {tag}", flush=True)
      failed.append(tag)
      continue
    verb = "adopted " if r.get("adopted_from") else "ran     "
    print(f"{verb} {tag}: PSNR {r['psnr']:.2f}  SSIM {r['ssim']:.3f}  LPIPS "
          f"{r['lpips'] if r['lpips'] is None else round(r['lpips'], 3)}  "
          f"{r['wall_s']:.0f} s training, {r['run_seconds']:.0f} s in all", flush=True)
  if failed:
    sys.exit(f"{len(failed)} run(s) failed: {', '.join(failed)}")


def cli():
  """The tool's entry point (python -m experiments.<tool>)."""
  define_flags()
  tool.run(sys.modules[__name__], main)


if __name__ == "__main__":
  cli()
