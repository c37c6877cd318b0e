"""LPIPS (and 8-bit PSNR / SSIM) of a compare workdir's saved renders.

  python -m experiments.rescore_renders --workdir=DIR [--data_root=PATH]

For runs made where LPIPS could not be computed (on the GPU machine the VGG
weights do not travel; docs/gpu.md): reads each method's held-out renders,
DIR/<method>/<stage>/eval/<view>.png, scores them against the dataset's own
held-out images and adds to DIR/results.json, per method, `lpips`,
`psnr_8bit`, `ssim_8bit` and `rescored_from: "8-bit renders"`. The 8-bit
PSNR is there to show the quantisation's effect (it should match the float
`psnr` to about 0.01 dB); the float figures are kept unchanged.
"""
import json
import os

from absl import app, flags
import imageio.v3 as iio
import numpy as np

from halo_jax import checkpoint, datasets, evaluate

FLAGS = flags.FLAGS


def define_flags():
  """Defined on launch, not on import (the tests import this beside other scripts)."""
  flags.DEFINE_string("workdir", None, "A compare workdir (holds results.json).", required=True)
  flags.DEFINE_string("data_root", "", "Replaces each run's data.root (data moved since).")


def rescore_method(method_dir: str, data_root: str, stage: str = "") -> dict:
  """{'lpips', 'psnr_8bit', 'ssim_8bit', 'per_view'} of one method's output
  stage's saved renders: `stage`, or where it is '' the one stage whose eval/
  folder holds them."""
  stages = [s for s in sorted(os.listdir(method_dir))
            if os.path.isfile(os.path.join(method_dir, s, "eval", "metrics.json"))]
  if stage:
    if stage not in stages:
      raise ValueError(f"{method_dir}: stage {stage!r} has no eval/metrics.json (found {stages})")
    stages = [stage]
  if len(stages) != 1:
    raise ValueError(f"{method_dir}: expected one stage with eval/metrics.json, found {stages}")
  stage_dir = os.path.join(method_dir, stages[0])
  config = checkpoint.read_config(os.path.join(stage_dir, "final", "config.json"))
  if data_root:
    config.data.root = data_root
  views = datasets.load(config.data, method_dir).test
  renders = []
  for name in views.names:
    path = os.path.join(stage_dir, "eval", f"{name}.png")
    if not os.path.isfile(path):
      raise FileNotFoundError(f"{path}: the render of held-out view {name} is missing")
    # evaluate.evaluate's strip: [ground truth | render | depth], side by side
    strip = iio.imread(path)[..., :3]
    width = strip.shape[1] // 3
    renders.append(strip[:, width:2 * width].astype(np.float32) / 255.0)
  per = evaluate.score(np.stack(renders), views.images, with_lpips=True)
  return {"lpips": float(np.mean(per["lpips"])), "psnr_8bit": float(np.mean(per["psnr"])),
          "ssim_8bit": float(np.mean(per["ssim"])),
          "per_view": {n: {k: per[k][i] for k in per} for i, n in enumerate(views.names)}}


def main(_):
  path = os.path.join(FLAGS.workdir, "results.json")
  with open(path) as f:
    results = json.load(f)
  for method, r in results.items():
    # the output stage is the last one the method trained (results.json keeps their order)
    s = rescore_method(os.path.join(FLAGS.workdir, method), FLAGS.data_root,
                       list(r["stages"])[-1])
    for view, scores in s.pop("per_view").items():
      r["per_view"].setdefault(view, {})["lpips"] = scores["lpips"]
    r.update(s, rescored_from="8-bit renders")
    print(f"{method}: PSNR {r['psnr']:.3f} (8-bit {r['psnr_8bit']:.3f}), "
          f"SSIM {r['ssim_8bit']:.3f}, LPIPS {r['lpips']:.3f}")
  with open(path, "w") as f:
    json.dump(results, f, indent=1)


if __name__ == "__main__":
  define_flags()
  app.run(main)
