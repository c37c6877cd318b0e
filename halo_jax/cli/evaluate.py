"""Scores a finished stage on a split of its scene, without retraining.

  python -m halo_jax.cli.evaluate --workdir=DIR [--stage=hi] [--split=test] [--views=all]

Restores the stage (default: the run's output stage), renders the split's
views (for 'test', the views the run was evaluated on unless --views says
otherwise; 'train' is the training views), scores PSNR / SSIM / LPIPS on the
float renders (as training's own evaluation does) and on 8-bit renders
against 8-bit ground truth (as nerfbaselines and most published tables
score), and writes them to <out>/metrics.json, beside the renders in
nerfbaselines' layout (halo_jax/evaluate/predictions.py). <out> defaults to
DIR/<stage>/evaluate-<split>.
"""
import json
import os

from absl import app, flags
import numpy as np

from halo_jax import datasets, evaluate, frozen, provenance, restore
from halo_jax.evaluate import predictions
from halo_jax.cli import launch
from halo_jax.stages import collapse

FLAGS = flags.FLAGS


def define_flags():
  """The command's flags (defined on launch, not on import, so that both
  commands' functions can be imported together)."""
  flags.DEFINE_string("workdir", None, "A run folder written by halo-train.")
  flags.DEFINE_string("stage", None, "Stage to score (default: the run's output stage).")
  flags.DEFINE_string("split", "test", "'test', 'train', or another split of the scene "
                      "(e.g. 'val' for D-NeRF).")
  flags.DEFINE_string("views", "", "Views of the split: 'all', 'every:K' or names "
                      "(default: those the run used).")
  flags.DEFINE_string("out", None, "Output folder (default DIR/<stage>/evaluate-<split>).")
  flags.DEFINE_string("data_root", "", "Scene folder, if not where the run found it.")
  flags.DEFINE_bool("lpips", True, "Also score LPIPS (VGG).")
  flags.mark_flags_as_required(["workdir"])


def split_views(run: restore.Restored, split: str, views: str):
  """The Views to score: the run's own test or training views, or a split
  loaded with the view list `views`."""
  if split == "test" and not views:
    return run.dataset.test
  if split == "train" and not views:
    return run.dataset.train
  data = frozen.thaw(run.config.data)  # a view list of the run's scene
  if split == "train":
    data.train_views = views
    return datasets.load(data, run.workdir).train
  data.test_split, data.test_views = split, views or "all"
  return datasets.load(data, run.workdir).test


def scores(rgb, gt, names, with_lpips):
  """{'psnr', 'ssim'[, 'lpips'], 'per_view': {name: {...}}}."""
  per = evaluate.score(rgb, gt, with_lpips)
  out = {k: float(np.mean(v)) for k, v in per.items()}
  out["per_view"] = {n: {k: v[i] for k, v in per.items()} for i, n in enumerate(names)}
  return out


def to_8bit(x):
  return np.round(np.clip(x, 0.0, 1.0) * 255.0) / 255.0


def run_evaluation(workdir, stage=None, split="test", views="", out=None, data_root="",
                   with_lpips=True, render_overrides=()) -> dict:
  """Renders, scores and writes; returns the metrics.json contents
  (render_overrides: restore.load's)."""
  run = restore.load(workdir, stage, data_root, render_overrides)
  vs = split_views(run, split, views)
  r = evaluate.render_views(run.render, vs, run.config.eval.chunk,
                            desc=f"evaluate {run.stage} on {split}")
  rgb = np.clip(r["rgb"], 0.0, 1.0)
  result = {"stage": run.stage, "split": split, "num_views": len(vs.names),
            "float": scores(rgb, vs.images, vs.names, with_lpips),
            "uint8": scores(to_8bit(rgb), to_8bit(vs.images), vs.names, with_lpips),
            # the best constant image's PSNR on these views (stages/collapse.py)
            "constant_psnr": collapse.constant_psnr(vs.images),
            "note": "float: renders clipped to [0, 1] against the loaded ground truth, as "
                    "training evaluates; uint8: both rounded to 8 bits first."}
  out = out or os.path.join(workdir, run.stage, f"evaluate-{split}")
  near, far = (run.dataset.near, run.dataset.far) if run.dataset.geometry.value == "sphere" \
      else (0.0, 1.0)
  predictions.write(out, vs.names, rgb, vs.images, r["depth"], r["acc"], near, far, {
      "method": run.config.get("method", "halo"), "stage": run.stage, "split": split,
      "scene": {"kind": run.config.data.kind, "root": run.config.data.root},
      "depth_units": run.dataset.facts.depth_units,
      "provenance": provenance.collect()})
  with open(os.path.join(out, "metrics.json"), "w") as f:
    json.dump(result, f, indent=1)
  result["out"] = out
  return result


def main(argv):
  del argv
  with launch():
    r = run_evaluation(FLAGS.workdir, FLAGS.stage, FLAGS.split, FLAGS.views, FLAGS.out,
                       FLAGS.data_root, FLAGS.lpips)
  print(f"{r['stage']} on {r['num_views']} {r['split']} views")
  for kind in ("float", "uint8"):
    m = r[kind]
    lp = f"  LPIPS {m['lpips']:.4f}" if "lpips" in m else ""
    print(f"  {kind:5}  PSNR {m['psnr']:.4f}  SSIM {m['ssim']:.4f}{lp}")
  print(f"wrote {r['out']} (metrics.json, color/, gt-color/, depth/, depth-rgb/, acc/, "
        "info.json)")


def cli():
  """The halo-eval console script."""
  define_flags()
  app.run(main)


if __name__ == "__main__":
  cli()
