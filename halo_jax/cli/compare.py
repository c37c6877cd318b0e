"""Every method on the same views with the same training budget.

  halo-compare --config=configs/blender.py:lego_8view_cpu --workdir=DIR

Trains each of --methods (default: the registry's compared methods;
docs/baselines.md) for `config.budget_s` reference seconds (the 'budget'
protocol: the same steps on any machine, none past the budget), evaluates
all on the same held-out views and writes DIR/results.json, results.md and
psnr_vs_time.png. --all_views_reference also trains nerf_tuned on every
training view (the upper reference). Launched again with the same flags, a
killed run resumes each method from its last checkpoint.

Each method trains in a process of its own pinned to one core, as many at
once as the launch has cores (--at_once): a method's figures then follow its
steps and one core's arithmetic, whatever the machine's core count. Its
progress bars go to DIR/<method>/progress.log; the command's own bar counts
the methods.
"""
import concurrent.futures
import contextlib
import json
import multiprocessing
import os
import sys

from absl import flags
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # pylint: disable=g-import-not-at-top

from halo_jax import datasets, methods, pipeline, progress, runs, tables
from halo_jax.cli import run_app, config_of_flags, define_config_flag, launch

FLAGS = flags.FLAGS


def define_flags():
  """The command's flags, defined on launch (the tests import this module)."""
  define_config_flag()
  flags.DEFINE_string("workdir", None, "Output folder.")
  flags.DEFINE_bool("all_views_reference", False, "Also train NeRF on all training views.")
  flags.DEFINE_integer("curve_points", 4, "Held-out evaluations per method for the curve.")
  flags.DEFINE_list("methods", list(methods.with_role(methods.base.COMPARED)),
                    "Methods to train (names in halo_jax.methods.METHODS); results of others "
                    "already in DIR/results.json are kept.")
  flags.DEFINE_integer("at_once", 0, "Methods trained at once, one core each (0: as many as "
                       "the launch has cores; 1: one after another, still on one core).")
  flags.mark_flags_as_required(["config", "workdir"])


def _run_fields(c) -> dict:
  """The fields this command sets on a method's config: the built-in
  scene's folder (generated once, shared) and the held-out curve's spacing."""
  fields = {}
  if c.data.kind == "procedural" and not c.data.root:
    fields["data.root"] = os.path.join(FLAGS.workdir, f"scene_{c.data.procedural_scene}")
  for name in pipeline.stage_names(c):
    fields[f"{name}.eval_every_s"] = (c.budget_s / max(FLAGS.curve_points, 1)
                                      if c.budget_s else 0.0)
  return fields


def method_configs(load, names, all_views):
  """{method: its config on this scene} (halo_jax.methods), plus
  nerf_tuned on every training view with all_views. load: (method,
  overrides) -> that method's composed config (configure.compose)."""
  runs_of = {name: (name, {}) for name in names}
  if all_views:
    runs_of["nerf_tuned_all_views"] = ("nerf_tuned", {"data.train_views": "all"})
  out = {}
  for key, (method, fields) in runs_of.items():
    out[key] = load(method, {**fields, **_run_fields(load(method, fields))})
  return out


def reach_lines(results, lead="halo") -> str:
  """A line per other method: when `lead`'s held-out curve first reached that
  method's last curve point (both on the curve views, the reference clock),
  and the share of the other's time that is; '' without `lead` or curves."""
  if lead not in results or not results[lead].get("curve"):
    return ""
  lines = []
  for name, r in results.items():
    if name == lead or not r.get("curve"):
      continue
    end_s, end_psnr = r["curve"][-1]
    t = runs.seconds_to_reach([results[lead]], end_psnr)
    reached = (f"at {t:.0f} s, {t / end_s:.2f} of its time" if t is not None
               else "not within its run")
    lines.append(f"- {lead} reaches {name}'s final curve PSNR ({end_psnr:.2f} dB at "
                 f"{end_s:.0f} s) {reached}.")
  return "\n" + "\n".join(lines) + "\n" if lines else ""


def write_report(results, workdir, n_test):
  dynamic = any("flicker" in r for r in results.values())
  level = runs.common_level(list(results.values()))
  reach = f"s to {level:.1f} dB" if level is not None else ""
  header = (["method", "held-out PSNR", "SSIM", "LPIPS (VGG)"] + (["flicker"] if dynamic else [])
            + ["reference s", "wall s"] + ([reach] if reach else []) + ["learned"])
  rows = []
  for name, r in results.items():
    rows.append([name, f"{r['psnr']:.2f}", f"{r['ssim']:.3f}", tables.cell(r.get("lpips"), ".3f")]
                + ([tables.cell(r.get("flicker"), ".2f")] if dynamic else [])
                + [tables.cell(r.get("reference_s"), ".0f"), f"{r['wall_s']:.0f}"]
                + ([tables.cell(runs.seconds_to_reach([r], level), ".0f")] if reach else [])
                + [runs.learned_cell(r)])
  note = (" Flicker: mean |I(t+1) - 2 I(t) + I(t-1)| in 8-bit levels over a video at the "
          "first held-out camera (halo_jax.metrics.temporal_flicker)." if dynamic else "")
  note += (" 'learned': whether every stage beat the best constant image on its training "
           "rays (halo_jax/stages/collapse.py); a collapsed method's figures are its "
           "collapsed stage's.")
  note += (" 'reference s': the training the budget paid for, in the reference machine's "
           "seconds; 'wall s': this machine's.")
  if reach:
    note += (f" 's to {level:.1f} dB': reference seconds until the held-out curve (the first "
             f"eval.curve_views views) first reached {level:.1f} dB, 0.5 dB under the lowest "
             "curve peak of all methods.")
  table = (tables.markdown(header, rows) + f"\n\n({n_test} held-out views.{note})\n"
           + reach_lines(results))
  with open(os.path.join(workdir, "results.md"), "w") as f:
    f.write(table)
  plot_curves(results, os.path.join(workdir, "psnr_vs_time.png"))
  return table


def plot_curves(results, path, size=(6, 4), dpi=120):
  """Each method's held-out curve (PSNR against reference seconds) in one PNG."""
  plt.figure(figsize=size)
  for name, r in results.items():
    if r.get("curve"):
      t, p = zip(*r["curve"])
      plt.plot(t, p, marker="o", label=name)
  plt.xlabel("training (reference seconds)")
  plt.ylabel("held-out PSNR (dB), curve views")
  plt.grid(alpha=0.3)
  plt.legend()
  plt.tight_layout()
  plt.savefig(path, dpi=dpi)
  plt.close()


def main(argv):
  del argv
  with launch(FLAGS.workdir):
    run(FLAGS.config)


def _pin(cores):
  """A worker's start: one core of its own, taken before JAX starts its
  thread pool, so XLA computes with one thread."""
  if hasattr(os, "sched_setaffinity"):
    os.sched_setaffinity(0, {cores.get()})


def _train(name, cfg, workdir):
  """One method in its worker: (name, held-out views, its record). Its bars
  and XLA's messages go to <workdir>/<name>/progress.log."""
  folder = os.path.join(workdir, name)
  os.makedirs(folder, exist_ok=True)
  with open(os.path.join(folder, "progress.log"), "a") as log:
    os.dup2(log.fileno(), 2)
    with contextlib.redirect_stderr(log):
      dataset = datasets.load(cfg.data, folder)
      return name, len(dataset.test.names), runs.run_method(cfg, folder, dataset)


def _cores() -> list:
  return sorted(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else [0]


def train_all(configs, workdir, at_once=0):
  """Yields (name, held-out views, record) of each method of `configs`
  ({name: config}) as it finishes, `at_once` at a time (0: one per core of
  this launch), each worker pinned to a core of its own."""
  cores = _cores()
  width = max(1, min(at_once or len(cores), len(cores), len(configs)))
  ctx = multiprocessing.get_context("spawn")  # a fresh JAX in each worker
  queue = ctx.Queue()
  for core in cores[:width]:
    queue.put(core)
  with concurrent.futures.ProcessPoolExecutor(width, mp_context=ctx, initializer=_pin,
                                              initargs=(queue,)) as pool:
    todo = [pool.submit(_train, name, cfg, workdir) for name, cfg in configs.items()]
    for done in concurrent.futures.as_completed(todo):
      yield done.result()


def run(config):
  """The experiment in FLAGS.workdir (locked by main); `config` is --config's
  scene, which each method is made from (cli.config_of_flags)."""
  os.makedirs(FLAGS.workdir, exist_ok=True)
  results_path = os.path.join(FLAGS.workdir, "results.json")
  results = {}
  if os.path.exists(results_path):
    with open(results_path) as f:
      results = json.load(f)
  n_test = 0
  del config
  load = lambda name, fields: config_of_flags(FLAGS["config"], name, fields)  # pylint: disable=unnecessary-lambda-assignment
  configs = method_configs(load, FLAGS.methods, FLAGS.all_views_reference)
  # the data checked, and a built-in scene generated, here once, before the workers share it
  name, first = next(iter(configs.items()))
  datasets.load(first.data, os.path.join(FLAGS.workdir, name))
  print(f"training {', '.join(configs)}; each method's progress: "
        f"{os.path.join(FLAGS.workdir, '<method>', 'progress.log')}", file=sys.stderr)
  finished = progress.steps(train_all(configs, FLAGS.workdir, FLAGS.at_once), "methods",
                            "halo-compare", total=len(configs))
  for name, n_test, record in finished:
    results[name] = record
    print(f"{name}: held-out PSNR {record['psnr']:.2f} after {record['reference_s']:.0f} "
          f"reference s ({record['wall_s']:.0f} s here)", file=sys.stderr)
    with open(results_path, "w") as f:
      json.dump(results, f, indent=1)
  ordered = {n: results[n] for n in configs}
  ordered.update({n: r for n, r in results.items() if n not in configs})
  with open(results_path, "w") as f:
    json.dump(ordered, f, indent=1)
  print(write_report(ordered, FLAGS.workdir, n_test))
  collapsed = [f"{n} ({r['collapsed']['stage']})" for n, r in ordered.items() if "collapsed" in r]
  if collapsed:
    print(f"error: {len(collapsed)} method(s) learned nothing: {', '.join(collapsed)} "
          "(a stage no better than the best constant image on its training rays; "
          "their rows above are flagged)", file=sys.stderr)
    raise SystemExit(2)


def cli():
  """The halo-compare console script."""
  define_flags()
  run_app(main)


if __name__ == "__main__":
  cli()
