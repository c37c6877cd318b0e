"""Every method on the same views with the same training budget.

  halo-compare --config=configs/blender.py:lego_8view_cpu --workdir=DIR

Trains each of --methods (default: the registry's compared methods;
docs/baselines.md) for `config.budget_s` reference seconds (the 'budget'
protocol: the same steps on any machine, none past the budget), evaluates
all on the same held-out views and writes DIR/results.json, results.md and
psnr_vs_time.png. --all_views_reference also trains nerf_tuned on every
training view (the upper reference). Launched again with the same flags, a
killed run resumes each method from its last checkpoint.
"""
import json
import os
import sys

from absl import flags
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # pylint: disable=g-import-not-at-top

from halo_jax import datasets, methods, pipeline, runs, tables
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
  table = tables.markdown(header, rows) + f"\n\n({n_test} held-out views.{note})\n"
  with open(os.path.join(workdir, "results.md"), "w") as f:
    f.write(table)
  plt.figure(figsize=(6, 4))
  for name, r in results.items():
    if r["curve"]:
      t, p = zip(*r["curve"])
      plt.plot(t, p, marker="o", label=name)
  plt.xlabel("training (reference seconds)")
  plt.ylabel("held-out PSNR (dB), curve views")
  plt.grid(alpha=0.3)
  plt.legend()
  plt.tight_layout()
  plt.savefig(os.path.join(workdir, "psnr_vs_time.png"), dpi=120)
  return table


def main(argv):
  del argv
  with launch(FLAGS.workdir):
    run(FLAGS.config)


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
  for name, cfg in method_configs(load, FLAGS.methods, FLAGS.all_views_reference).items():
    dataset = datasets.load(cfg.data, os.path.join(FLAGS.workdir, name))
    n_test = len(dataset.test.names)
    results[name] = runs.run_method(cfg, os.path.join(FLAGS.workdir, name), dataset)
    with open(results_path, "w") as f:
      json.dump(results, f, indent=1)
  print(write_report(results, FLAGS.workdir, n_test))
  collapsed = [f"{n} ({r['collapsed']['stage']})" for n, r in results.items() if "collapsed" in r]
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
