"""Chooses Lo-NeRF's P.E. frequency (L, s) with the frequency criterion.

  python -m experiments.tune_frequency --config=configs/blender.py:lego_8view_cpu \
      --workdir=DIR [--full_grid] [--config.tune.grid=10:1,5:8,5:32] [--config.tune.lo_steps=300]

Trains a short Lo-NeRF per point of `config.tune.grid`, from the highest
frequency 2^(L-1)/s to the lowest, computes the criterion on pairs of nearby
renders (halo_jax/frequency/tuning.py) and stops at the first point below
`config.tune.threshold`. With --full_grid every point is trained and scored.
Writes DIR/results.json ({"grid": [{"L", "scale", "criterion", "psnr", ...}],
"chosen": {"L", "scale"}}), DIR/results.md and DIR/criterion_vs_psnr.png, and
prints the table. Use the choice with
`python -m halo_jax.cli.train ... --config.lo.encoding.L=<L> --config.lo.encoding.scale=<s>`,
or let a launch search by itself with `--config.lo.encoding.auto=True`.
"""
import os

from absl import app, flags
from ml_collections import config_flags

from halo_jax import datasets, pipeline, plots, tables
from halo_jax.frequency import tuning
from halo_jax.cli import config_of_flags, define_method_flag, launch

FLAGS = flags.FLAGS
config_flags.DEFINE_config_file("config", None, "HALO config (path[:variant]).",
                                lock_config=True)
flags.DEFINE_string("workdir", None, "Output folder (one sub-folder per grid point).")
flags.DEFINE_bool("full_grid", False, "Train and score every grid point.")
define_method_flag()
flags.mark_flags_as_required(["config", "workdir"])


def report(result, workdir):
  """Writes results.md and criterion_vs_psnr.png; returns the table."""
  chosen = (result["chosen"]["L"], result["chosen"]["scale"])
  best = max((g for g in result["grid"] if g["psnr"] is not None), key=lambda g: g["psnr"])
  rows = []
  for g in result["grid"]:
    mark = []
    if (g["L"], g["scale"]) == chosen:
      mark.append("chosen")
    if g is best:
      mark.append("best PSNR")
    rows.append([str(g["L"]), f"{g['scale']:g}", f"{g['max_freq']:g}",
                 tables.cell(g["criterion"], ".4f"), tables.cell(g["psnr"], ".2f"),
                 tables.cell(g["ssim"], ".3f"), f"{g['wall_s']:.0f}", ", ".join(mark)])
  lines = [tables.markdown(["L", "s", "max freq 2^(L-1)/s", "rho", "held-out PSNR", "SSIM",
                            "train s", ""], rows)]
  chosen_psnr = next(g["psnr"] for g in result["grid"] if (g["L"], g["scale"]) == chosen)
  lines.append("")
  lines.append(f"Threshold {result['threshold']:g}: chosen L={chosen[0]}, s={chosen[1]:g} "
               f"({'first point below the threshold' if result['below_threshold'] else 'no point below the threshold: the lowest frequency'}); "
               f"its held-out PSNR is {best['psnr'] - chosen_psnr:.2f} dB below the grid's best.")
  table = "\n".join(lines) + "\n"
  with open(os.path.join(workdir, "results.md"), "w") as f:
    f.write(table)
  plots.criterion_and_psnr([f"L{g['L']}/s{g['scale']:g}" for g in result["grid"]],
                           [g["criterion"] for g in result["grid"]],
                           [g["psnr"] for g in result["grid"]],
                           os.path.join(workdir, "criterion_vs_psnr.png"),
                           threshold=result["threshold"],
                           xlabel="Lo-NeRF P.E. (high to low frequency)")
  return table


def main(argv):
  del argv
  with launch(FLAGS.workdir):
    run(config_of_flags(FLAGS["config"], FLAGS.method))


def run(config):
  """The experiment in FLAGS.workdir (locked by main)."""
  os.makedirs(FLAGS.workdir, exist_ok=True)
  dataset = datasets.load(config.data, FLAGS.workdir)
  result = tuning.tune(config, FLAGS.workdir, dataset, pipeline.run, FLAGS.full_grid)
  print(report(result, FLAGS.workdir))


if __name__ == "__main__":
  app.run(main)
