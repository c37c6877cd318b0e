"""NeRF vs HALO on the same views with the same training wall-clock budget.

  python experiments/few_shot.py --config=configs/blender.py:lego_8view_cpu --workdir=DIR

Trains the vanilla-NeRF baseline (`defaults.as_nerf_baseline`: the Hi stage
alone, stratified samples, no regulariser) and HALO (lo -> ray -> hi), each
for `config.budget_s` seconds of training (held-out evaluations for the curves
are not counted), evaluates both on the same held-out views and writes
DIR/results.json, DIR/results.md and DIR/psnr_vs_time.png. With
--all_views_reference it also trains NeRF on every training view for the
same budget (the upper reference). A killed run, launched again with the same
flags, resumes each method from its last checkpoint (finished stages are not
retrained: their final states are in DIR/<method>).
"""
import copy
import json
import os

from absl import app, flags, logging
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # pylint: disable=g-import-not-at-top
from ml_collections import config_flags

from halo_jax import datasets, defaults, stages

FLAGS = flags.FLAGS
config_flags.DEFINE_config_file("config", None, "HALO config (path[:variant]).",
                                lock_config=True)
flags.DEFINE_string("workdir", None, "Output folder.")
flags.DEFINE_bool("all_views_reference", False, "Also train NeRF on all training views.")
flags.DEFINE_integer("curve_points", 8, "Held-out evaluations per method for the curve.")
flags.DEFINE_list("methods", None, "Train only these methods (nerf, halo, nerf_all_views); "
                  "results of the others already in DIR/results.json are kept.")
flags.mark_flags_as_required(["config", "workdir"])


def read_curve(workdir):
  """[[training seconds, held-out PSNR], ...] from a run's metrics.jsonl."""
  with open(os.path.join(workdir, "metrics.jsonl")) as f:
    recs = [json.loads(line) for line in f]
  return [[r["wall_s"], r["psnr"]] for r in recs if r.get("heldout")]


def run_method(config, workdir, dataset):
  infos = stages.run(config, workdir, dataset)
  last = infos[stages.parse_stages(config.stages)[-1]]
  return {"psnr": last["eval"]["psnr"], "ssim": last["eval"]["ssim"],
          "lpips": last["eval"].get("lpips", float("nan")),
          **({"flicker": last["eval"]["flicker"]} if "flicker" in last["eval"] else {}),
          "wall_s": sum(i["wall_s"] for i in infos.values()),
          "stages": {n: {"wall_s": i["wall_s"], "step": i["step"],
                         **({"psnr": i["eval"]["psnr"]} if "eval" in i else {})}
                     for n, i in infos.items()},
          "curve": read_curve(workdir)}


def methods(config, all_views):
  halo = copy.deepcopy(config)
  nerf = defaults.as_nerf_baseline(copy.deepcopy(config))
  out = {"nerf": nerf, "halo": halo}
  if all_views:
    ref = copy.deepcopy(nerf)
    ref.data.train_views = "all"
    out["nerf_all_views"] = ref
  for c in out.values():
    for name in stages.ORDER:
      c[name].eval_every_s = c.budget_s / max(FLAGS.curve_points, 1) if c.budget_s else 0.0
  return out


def write_report(results, workdir, n_test):
  dynamic = any("flicker" in r for r in results.values())
  lines = ["| method | held-out PSNR | SSIM | LPIPS (VGG) |" + (" flicker |" if dynamic else "")
           + " training s |", "|---|---|---|---|" + ("---|" if dynamic else "") + "---|"]
  for name, r in results.items():
    flicker = f" {r.get('flicker', float('nan')):.2f} |" if dynamic else ""
    lines.append(f"| {name} | {r['psnr']:.2f} | {r['ssim']:.3f} | {r.get('lpips', float('nan')):.3f} "
                 f"|{flicker} {r['wall_s']:.0f} |")
  note = (" Flicker: mean |I(t+1) - 2 I(t) + I(t-1)| in 8-bit levels over a video at the "
          "first held-out camera (halo_jax.metrics.temporal_flicker)." if dynamic else "")
  table = "\n".join(lines) + f"\n\n({n_test} held-out views.{note})\n"
  with open(os.path.join(workdir, "results.md"), "w") as f:
    f.write(table)
  plt.figure(figsize=(6, 4))
  for name, r in results.items():
    if r["curve"]:
      t, p = zip(*r["curve"])
      plt.plot(t, p, marker="o", label=name)
  plt.xlabel("training wall-clock (s)")
  plt.ylabel("held-out PSNR (dB), curve views")
  plt.grid(alpha=0.3)
  plt.legend()
  plt.tight_layout()
  plt.savefig(os.path.join(workdir, "psnr_vs_time.png"), dpi=120)
  return table


def main(argv):
  del argv
  logging.set_verbosity(logging.WARNING)
  config = FLAGS.config
  os.makedirs(FLAGS.workdir, exist_ok=True)
  results_path = os.path.join(FLAGS.workdir, "results.json")
  results = {}
  if FLAGS.methods and os.path.exists(results_path):
    with open(results_path) as f:
      results = json.load(f)
  n_test = 0
  for name, cfg in methods(config, FLAGS.all_views_reference).items():
    if FLAGS.methods and name not in FLAGS.methods:
      continue
    dataset = datasets.load(cfg.data, os.path.join(FLAGS.workdir, name))
    n_test = len(dataset.test.names)
    results[name] = run_method(cfg, os.path.join(FLAGS.workdir, name), dataset)
    with open(results_path, "w") as f:
      json.dump(results, f, indent=1)
  print(write_report(results, FLAGS.workdir, n_test))


if __name__ == "__main__":
  app.run(main)
