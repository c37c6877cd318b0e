"""Re-scores a `halo-eval` output with nerfbaselines, the field's harness, and
compares its PSNR and SSIM with ours.

nerfbaselines pins numpy below 2, so it lives in a venv of its own:

  python3 -m venv /tmp/nbvenv && /tmp/nbvenv/bin/pip install nerfbaselines
  halo-eval --workdir=RUN --out=PRED
  /tmp/nbvenv/bin/python -m experiments.nerfbaselines_check PRED OUT.json

It runs `nerfbaselines evaluate` on PRED unchanged. Its protocol also scores
LPIPS, whose AlexNet / VGG backbones torchvision downloads at first use; where
that fails (no network, or no torch), the same reading of PRED is scored by
nerfbaselines' own evaluation loop and metric functions with the LPIPS
columns left out, and OUT.json says why. Prints one line per metric: ours,
nerfbaselines', the difference.
"""
import json
import os
import subprocess
import sys
import tempfile


def _full_evaluate(pred, out):
  """`nerfbaselines evaluate` as a user runs it: (results or None, why not)."""
  exe = os.path.join(os.path.dirname(sys.executable), "nerfbaselines")
  res = subprocess.run([exe, "evaluate", pred, "-o", out], capture_output=True, text=True)
  if res.returncode == 0:
    with open(out) as f:
      return json.load(f), ""
  lines = (res.stdout + res.stderr).replace("\r", "\n").splitlines()
  fetch = [line[line.index("Downloading"):] for line in lines if "Downloading" in line]
  error = [line.strip() for line in lines if "Error" in line]
  return None, " / ".join(fetch[-1:] + error[-1:])[:400]


def _without_lpips(pred, out):
  """nerfbaselines.evaluation.evaluate with its 'nerf' protocol minus LPIPS."""
  import numpy as np  # pylint: disable=g-import-not-at-top
  from nerfbaselines import evaluation, metrics  # pylint: disable=g-import-not-at-top

  class NoLpips(evaluation.NerfEvaluationProtocol):
    _name = "nerf"

    def evaluate(self, predictions, dataset):
      meta = dataset["metadata"]
      to = lambda x: evaluation.convert_image_dtype(evaluation.image_to_srgb(
          x, np.uint8, color_space=meta["color_space"],
          background_color=meta.get("background_color")), np.float32)
      p, g = to(predictions["color"])[None], to(dataset["images"][0])[None]
      mse = metrics.mse(p, g)
      return {"psnr": metrics.psnr(mse).mean().item(), "ssim": metrics.ssim(g, p).mean().item()}

  return evaluation.evaluate(pred, out, evaluation_protocol=NoLpips())


def _provenance():
  """Commit, tree state, machine and time, by git alone: this script runs in
  nerfbaselines' venv, which has no jax to import halo_jax.provenance with."""
  import platform  # pylint: disable=g-import-not-at-top
  import time  # pylint: disable=g-import-not-at-top
  repo = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")
  git = lambda *a: subprocess.run(["git", "-C", repo, *a], capture_output=True,  # noqa: E731
                                  text=True).stdout.strip()
  return {"git": {"commit": git("rev-parse", "HEAD") or None,
                  "dirty": bool(git("status", "--porcelain", "--untracked-files=no"))},
          "python": platform.python_version(), "host": platform.node(),
          "time_utc": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime())}


def main(pred, out):
  with tempfile.TemporaryDirectory() as tmp:
    full, why = _full_evaluate(pred, os.path.join(tmp, "full.json"))
    theirs = full if full is not None else _without_lpips(pred, os.path.join(tmp, "nolpips.json"))
  with open(os.path.join(pred, "metrics.json")) as f:
    scores = json.load(f)
  ours = scores["uint8"]  # nerfbaselines scores the 8-bit PNGs, as we do here
  rows = {}
  for k in ("psnr", "ssim", "lpips"):
    if k in theirs["metrics"] and k in ours:
      rows[k] = {"ours": ours[k], "nerfbaselines": theirs["metrics"][k],
                 "difference": theirs["metrics"][k] - ours[k]}
      print(f"{k:6s} ours {ours[k]:.5f}  nerfbaselines {theirs['metrics'][k]:.5f}  "
            f"difference {rows[k]['difference']:+.1e}")
  import nerfbaselines  # pylint: disable=g-import-not-at-top
  result = {"nerfbaselines": nerfbaselines.__version__, "full_evaluate": full is not None,
            "why_not_full": why, "num_views": scores["num_views"],
            "metrics": rows,
            # where the scores came from: the predictions folder, the code and machine
            "predictions": os.path.abspath(pred),
            "provenance": _provenance()}
  with open(out, "w") as f:
    json.dump(result, f, indent=1)
  if not full:
    print(f"nerfbaselines evaluate stopped before its LPIPS: {why}")


if __name__ == "__main__":
  if set(sys.argv[1:]) & {"-h", "--help", "--helpfull"}:
    print(__doc__)
  elif len(sys.argv) != 3:
    sys.exit("usage: python -m experiments.nerfbaselines_check PRED OUT.json (--help: more)")
  else:
    main(*sys.argv[1:3])
