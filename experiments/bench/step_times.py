"""The step table (halo_jax/step_table.py): the reference seconds behind the
'budget' protocol, and the command that measures it.

  python -m experiments.step_times --from_records        # the table from the CPU suite's committed runs
  python -m experiments.step_times                       # measure the keys the suites use that the table lacks
  python -m experiments.step_times --remeasure           # measure every key again (this machine becomes the reference)
  python -m experiments.step_times --dry_run             # which keys are there, which are missing

The reference machine is the one that ran the CPU suite's seeds 0 and 1
(results/cpu/time, 2026-11-26): `--from_records` takes each key's step time
from those runs (their loop seconds over their steps; the ray field's
target rendering as its set-up), so that a 240-s budget trains the steps
those runs reached. A key they lack is measured here, and put in the
reference machine's seconds by the ratio of an anchor key measured in the
same session (`--anchor`, a (scene, method) whose keys the table has);
with --remeasure no ratio applies.

For each (scene, method) of the CPU, validation, stress and smoke suites, the
keys of its stages (one per method, scene kind, stage and size): a key the
table lacks is measured by a short step-capped run of the method on that
scene, pinned to one core like the suites' runs (--core), with the run's
held-out scoring off. A stage's step time is its loop's training seconds
over its steps; its set-up (rendering Lo-NeRF's targets or banks) is recorded
apart. The table's `machine` record says where and with which code it was
measured. Every scene of one kind and size shares its key, so a scene outside
the suites finds its entry without a measurement of its own.
"""
import dataclasses
import json
import os
import statistics
import shutil
import sys
import time

from absl import flags, logging

from halo_jax import atomic, frozen, pipeline, progress, protocol, sampler_switch
from halo_jax import step_table
from halo_jax.configure import finish
from experiments.bench import git_state
from experiments.bench import benchmark, selection, studies, suites, tool

FLAGS = flags.FLAGS
RECORD_SEEDS = (0, 1)

# Suites whose keys the table covers, with the suite whose terms configure them.
SUITES = (("cpu", suites.CPU, suites.CPU.scenes),
          ("validation", suites.CPU, suites.VALIDATION_SCENES),
          ("smoke", suites.SMOKE, suites.SMOKE.scenes),
          # the authors' recipe in its studies (experiments/bench/studies.py),
          # with each study variant's changes to it
          ("authors", suites.CPU, tuple(
              dataclasses.replace(s, methods=("halo_authors",))
              for s in suites.VALIDATION_SCENES if not s.name.startswith("dnerf_"))
           + tuple(dataclasses.replace(s, methods=("halo_authors",),
                                       overrides=s.overrides + v.overrides)
                   for study in studies.STUDIES.values() for v in study.variants
                   if v.method == "halo_authors" and v.overrides for s in study.scenes)),
          # the variants of the studies that decide HALO's defaults at every
          # budget of the budget study: a variant of another size is a new key
          ("budget studies", suites.CPU, tuple(
              dataclasses.replace(s, methods=(v.method,), overrides=s.overrides + v.overrides)
              for name, study in studies.STUDIES.items() if name in studies.BUDGET_STUDIES
              for v in study.variants if v.overrides for s in study.scenes)))



def write_table(path: str, entries: dict, machine_record: dict) -> None:
  """Writes the step table (sorted, so a re-measure diffs line by line)."""
  step_table._read.cache_clear()  # pylint: disable=protected-access
  atomic.write_text(path, json.dumps(
      {"machine": machine_record, "entries": dict(sorted(entries.items()))},
      indent=1, sort_keys=True) + "\n")


# The groups above whose runs are the suites' (what a fingerprint covers): a
# study's variant records its own step counts, and a new one must not mark
# every suite's figures stale.
SUITE_GROUPS = ("cpu", "validation", "smoke")


def pairs(only: str = "", groups=None):
  """[(suite, scene, method)] of every suite, scene and method of `groups`
  (None: every group, studies' variants too), each once."""
  out, seen = [], set()
  for group, suite, scenes in SUITES:
    if groups is not None and group not in groups:
      continue
    for scene in scenes:
      for method in scene.methods:
        tag = (suite.budget_s, scene.config, scene.overrides, method)
        if tag not in seen:
          seen.add(tag)
          out.append((suite, scene, method))
  return selection.select(out, lambda r: f"{r[1].name}/{r[2]}", only, part="method",
                          plan="step table")


def keys_of(config) -> dict:
  """{stage: table key} of a method's config."""
  return {n: step_table.key(config, n) for n in pipeline.needed(config, config.final_stage)}


def switched_configs(config) -> dict:
  """{after-switch table key: (stage, the config whose stage samples so from
  its first step)} of the config's stages with a sampler switch
  (halo_jax/sampler_switch.py): the steps past a switch have their own key."""
  out = {}
  for n in pipeline.needed(config, config.final_stage):
    if sampler_switch.switch_step(config[n]):
      out[step_table.after_switch_key(config, n)] = (n, finish(sampler_switch.switched(config, n)))
  return out


def measuring_config(config, caps: dict):
  """The method's config step-capped at `caps` ({stage: steps}), its scoring
  cut to what a finished stage needs (its keys are those of `config`)."""
  c = protocol.steps(frozen.thaw(config), caps)
  for n in caps:
    c[n].update(eval_every=0, checkpoint_every=10 ** 6, select_best=False)
    c[n].min_steps = 0
  c.eval.update(lpips=False, save_images=False, front_s=(), curve_views=1, flicker_frames=3)
  return finish(c)


def measure(suite, scene, method, scratch, config=None) -> dict:
  """{key: {'step_s', 'setup_s', 'steps', 'wall_s'}} of one (scene, method),
  as the suite configures it or as `config` (its composed config) says."""
  c = config if config is not None else benchmark.configure(suite, scene, method, 0, "budget",
                                                            scratch)
  keys = keys_of(c)
  caps = {n: min(FLAGS.ray_steps if c[n].kind == "ray_field" else FLAGS.lo_steps, c[n].steps)
          for n in keys}
  workdir = os.path.join(scratch, "runs", scene.name, method)
  shutil.rmtree(workdir, ignore_errors=True)
  infos = pipeline.run(measuring_config(c, caps), workdir)
  out = {}
  for n, k in keys.items():
    info = infos[n]
    setup = float(info.get("setup_s", 0.0))
    loop_s = info["wall_s"] - setup
    out[k] = {"step_s": round(loop_s / info["step"], 6), "setup_s": round(setup, 3),
              "steps": int(info["step"]), "scene": scene.name, "method": method,
              "stage": n}
  shutil.rmtree(workdir, ignore_errors=True)
  return out


def from_records(results: str) -> dict:
  """{key: entry} from the CPU suite's result files of RECORD_SEEDS: each
  key's median step time over the runs that share it."""
  samples = {}
  for scene in suites.CPU.scenes:
    for method in scene.methods:
      for seed in RECORD_SEEDS:
        path = benchmark.result_path(results, "cpu", "time", scene, method, seed)
        if not os.path.exists(path):
          continue
        with open(path) as f:
          record = json.load(f)
        c = benchmark.configure(suites.CPU, scene, method, seed, "budget", "/tmp/halo_bench")
        for n, k in keys_of(c).items():
          stage = record["stages"][n]
          setup = float(stage.get("target_s", 0.0))
          samples.setdefault(k, []).append(
              ((stage["wall_s"] - setup) / stage["step"], setup, scene.name, method, n,
               record["provenance"]))
  out = {}
  for k, rows in samples.items():
    out[k] = {"step_s": round(statistics.median(r[0] for r in rows), 6),
              "setup_s": round(statistics.median(r[1] for r in rows), 3),
              "runs": len(rows), "scene": rows[0][2], "method": rows[0][3], "stage": rows[0][4],
              "source": "records"}
  return out


def _records_machine(results: str) -> dict:
  path = benchmark.result_path(results, "cpu", "time", suites.CPU.scenes[0], "nerf_tuned", 0)
  with open(path) as f:
    p = json.load(f)["provenance"]
  return {"cpu": p["cpu"]["model"], "cores_used": 1, "host": p["host"],
          "matmul_peak_gflops": p["matmul_peak_gflops"], "versions": p["versions"],
          "commit": p["git"]["commit"], "dirty": p["git"]["dirty"], "time_utc": p["time_utc"],
          "source": (f"results/cpu/time seeds {list(RECORD_SEEDS)}: 240-s runs on one core "
                     "each, two runs side by side")}


def anchor_ratio(entries, todo) -> float:
  """Reference seconds per second of this machine: the anchor's table step
  times over its times measured now (1 when the table has no anchor)."""
  del todo
  anchor = [t for t in pairs() if f"{t[1].name}/{t[2]}" == FLAGS.anchor][:1]  # the CPU suite's
  if not anchor:
    sys.exit(f"--anchor={FLAGS.anchor!r} is no scene/method of the suites")
  suite, scene, method = anchor[0]
  keys = keys_of(benchmark.configure(suite, scene, method, 0, "budget", FLAGS.scratch))
  if not all(k in entries for k in keys.values()):
    return 1.0
  now = measure(suite, scene, method, FLAGS.scratch)
  ratio = statistics.median(entries[k]["step_s"] / now[k]["step_s"] for k in keys.values())
  print(f"anchor {FLAGS.anchor}: the table's step times are {ratio:.3f}x this machine's now",
        flush=True)
  return ratio


def main(argv):
  del argv
  if hasattr(os, "sched_setaffinity"):  # one core, as the suites' runs
    allowed = sorted(os.sched_getaffinity(0))
    os.sched_setaffinity(0, [allowed[FLAGS.core]])
  logging.set_verbosity(logging.WARNING)
  if FLAGS.from_records:
    entries = from_records(FLAGS.results)
    write_table(FLAGS.table, entries, _records_machine(FLAGS.results))
    print(f"{len(entries)} keys from the records; the table at {FLAGS.table} was measured on "
          f"{_machine_line(step_table.machine(FLAGS.table))}")
    return
  entries = step_table.load(FLAGS.table)
  try:
    todo = pairs(FLAGS.only)
  except ValueError as e:
    sys.exit(str(e))
  done, ratio = 0, None
  for suite, scene, method in progress.steps(todo, "pairs", "step table"):
    tag = f"{scene.name}/{method}"
    if scene.needs and not os.path.isdir(os.path.join(benchmark.data_root(), scene.needs)):
      print(f"no data   {tag}", flush=True)
      continue
    c = benchmark.configure(suite, scene, method, 0, "budget", FLAGS.scratch)
    switched = switched_configs(c)
    missing = [k for k in list(keys_of(c).values()) + list(switched)
               if FLAGS.remeasure or k not in entries]
    if FLAGS.dry_run or not missing:
      print(f"{'missing' if missing else 'in table'} {tag}: {', '.join(missing)}", flush=True)
      continue
    if ratio is None:
      ratio = 1.0 if FLAGS.remeasure else anchor_ratio(entries, todo)
    t0 = time.time()
    measured = {}
    if any(k in missing for k in keys_of(c).values()):
      measured.update(measure(suite, scene, method, FLAGS.scratch))
    for k, (stage, sc) in switched.items():  # the steps after a sampler switch
      if k in missing:
        measured[k] = measure(suite, scene, method, FLAGS.scratch, sc)[step_table.key(sc, stage)]
    for v in measured.values():
      v.update(step_s=round(v["step_s"] * ratio, 6), setup_s=round(v["setup_s"] * ratio, 3),
               source="measured", ratio=round(ratio, 4))
    # a key two scenes share is measured once (--remeasure: the first one's)
    entries.update({k: v for k, v in measured.items() if k in missing})
    machine = step_table.machine(FLAGS.table) if ratio != 1.0 else _machine()
    write_table(FLAGS.table, entries, machine)
    done += 1
    print(f"measured {tag} in {time.time() - t0:.0f} s: " + ", ".join(
        f"{v['stage']} {v['step_s'] * 1e3:.1f} ms/step + {v['setup_s']:.1f} s"
        for v in measured.values()), flush=True)
  print(f"{done} measured; the table at {FLAGS.table} has {len(entries)} keys, measured on "
        f"{_machine_line(step_table.machine(FLAGS.table))}")


def _machine() -> dict:
  p = git_state.collect()
  return {"cpu": p["cpu"]["model"], "cores_used": 1, "host": p["host"],
          "matmul_peak_gflops": p["matmul_peak_gflops"], "versions": p["versions"],
          "commit": p["git"]["commit"], "dirty": p["git"]["dirty"], "time_utc": p["time_utc"],
          "timed_steps": {"radiance": FLAGS.lo_steps, "ray_field": FLAGS.ray_steps}}


def _machine_line(m: dict) -> str:
  if not m:
    return "no machine yet"
  return (f"{m['cpu']} (one core, matmul peak {m['matmul_peak_gflops']} GFLOP/s), "
          f"{m['time_utc']}, commit {str(m['commit'])[:12]}")


def define_flags():
  """This tool's flags, beside the runner's (--scratch: the measuring runs'
  workdirs, --only: a 'scene/method' regex, --dry_run: list the keys and
  whether the table has them)."""
  benchmark.define_flags()
  flags.DEFINE_string("table", step_table.TABLE, "The table to write.")
  flags.DEFINE_integer("core", -1, "The core the runs are pinned to (-1: the machine's last).")
  flags.DEFINE_bool("remeasure", False, "Measure keys the table already has too.")
  flags.DEFINE_integer("lo_steps", 80, "Steps a radiance stage is timed for.")
  flags.DEFINE_integer("ray_steps", 300, "Steps the ray field is timed for.")
  flags.DEFINE_bool("from_records", False, "Write the table from the CPU suite's result files "
                    "(seeds 0 and 1) and measure nothing.")
  flags.DEFINE_string("anchor", "spheres/nerf_tuned", "The (scene/method) measured beside new "
                      "keys to put them in the table's reference seconds.")


def cli():
  define_flags()
  tool.run(sys.modules[__name__], main)


if __name__ == "__main__":
  cli()
