"""The 2D toy of HALO's figure 2: low- vs high-frequency fields on images.

  python -m experiments.toy2d --workdir=DIR [--steps=3000] [--seeds=3]
  python -m experiments.toy2d --record       # the paper-size toy, kept: results/toy2d.json,
                                             # docs/results/toy2d.md, docs/images/toy2d.png
  python -m experiments.toy2d --report_only  # the page from the kept record

A field maps a pixel coordinate (in pixels of the 64x64 training grid) through
P.E. gamma(p; L, s) and an MLP to a colour. Lo: L=5, s=5; Hi: L=10, s=5 (the
paper's appendix).
(a) Interpolation: fit a 64x64 image (a 256x256 render of the procedural scene,
    box-filtered by 4) and render 256x256; error against the 256x256 render.
(b) Extrapolation: fit a 64x64 checkerboard (8-pixel squares) with its
    top-right 24x24 corner masked out; error on the masked corner.
Writes DIR/results.json ({"interp_mse": {"lo", "hi"}, "extrap_mse": {"lo", "hi"},
and per-seed values}) and DIR/toy2d.png, and prints the numbers. --record keeps
them with the commit, versions and machine that computed them; the page's
table is generated from that record (tests/test_generated_pages.py).
"""
import glob
import json
import os
import sys

from absl import app, flags
import flax.linen as nn
import jax
import jax.numpy as jnp
import matplotlib
import numpy as np
import optax

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # pylint: disable=g-import-not-at-top

from experiments.bench import git_state, tool  # pylint: disable=g-import-not-at-top
from experiments.bench.paths import REPO
from halo_jax import camera, encoding, models
from halo_jax.datasets import procedural

RECORD = os.path.join(REPO, "results", "toy2d.json")
PAGE = os.path.join(REPO, "docs", "results", "toy2d.md")
IMAGE = os.path.join(REPO, "docs", "images", "toy2d.png")

FLAGS = flags.FLAGS

FIELDS = {"lo": (5, 5.0), "hi": (10, 5.0)}
SIZE, UP, CHECK, CORNER = 64, 4, 8, 24


class Field2D(nn.Module):
  """Pixel coordinate [..., 2] -> colour [..., C] in (0, 1)."""
  freqs: int
  scale: float
  width: int = 128
  depth: int = 4
  channels: int = 3

  @nn.compact
  def __call__(self, xy):
    h = models.MLP(self.width, self.depth, ())(encoding.positional_encoding(xy, self.freqs,
                                                                           self.scale))
    return nn.sigmoid(nn.Dense(self.channels)(h))


def grid(size, up=1, unit=32.0):
  """Pixel-centre coordinates [size*up, size*up, 2].

  Training pixel i sits at (i + 0.5 - size / 2) / unit; the up-sampled pixels
  of pixel i are spread evenly around it, so box-filtering them gives pixel i.
  """
  c = ((np.arange(size * up) + 0.5) / up - 0.5 * size) / unit
  x, y = np.meshgrid(c, c, indexing="xy")
  return np.stack([x, y], -1).astype(np.float32)


def scene_image(size):
  """A [size, size, 3] analytic render of the procedural scene, on white."""
  c2w = camera.spherical_camera(2.7, 35.0, 30.0)
  focal = 0.5 * size / np.tan(0.5 * procedural.CAMERA_ANGLE_X)
  o, d = camera.pixel_rays(c2w, size, size, focal)
  rgba, _ = procedural.render_rays(o.reshape(-1, 3).astype(np.float64),
                                   d.reshape(-1, 3).astype(np.float64))
  rgb = rgba[:, :3] * rgba[:, 3:] + (1 - rgba[:, 3:])
  return rgb.reshape(size, size, 3).astype(np.float32)


def checkerboard(size, square):
  y, x = np.mgrid[0:size, 0:size]
  v = ((x // square + y // square) % 2).astype(np.float32) * 0.8 + 0.1
  return np.repeat(v[..., None], 3, -1)


def fit(freqs, scale, coords, target, mask, steps, seed, width, depth):
  """Fits a Field2D to target [H, W, C] on pixels where mask [H, W]; returns params."""
  model = Field2D(freqs, scale, width, depth, target.shape[-1])
  params = model.init(jax.random.PRNGKey(seed), coords[:1, :1])["params"]
  tx = optax.adam(optax.exponential_decay(1e-3, steps, 0.1))
  xy, y = jnp.asarray(coords[mask]), jnp.asarray(target[mask])

  def step(carry, _):
    p, s = carry
    loss, g = jax.value_and_grad(lambda q: jnp.mean((model.apply({"params": q}, xy) - y) ** 2))(p)
    u, s = tx.update(g, s, p)
    return (optax.apply_updates(p, u), s), loss

  (params, _), losses = jax.jit(lambda c: jax.lax.scan(step, c, None, length=steps))(
      (params, tx.init(params)))
  return model, params, float(losses[-1])


def run(steps, seeds, width, depth, unit=32.0):
  """Both tasks for both fields; returns (results dict, images for the figure)."""
  gt_hi = scene_image(SIZE * UP)
  train_img = gt_hi.reshape(SIZE, UP, SIZE, UP, 3).mean((1, 3))
  board = checkerboard(SIZE, CHECK)
  mask = np.ones((SIZE, SIZE), bool)
  mask[:CORNER, SIZE - CORNER:] = False            # the masked top-right corner
  g, g_up = grid(SIZE, 1, unit), grid(SIZE, UP, unit)
  res = {"interp_mse": {}, "extrap_mse": {}, "train_mse": {}, "per_seed": {}}
  images = {"gt_hi": gt_hi, "train": train_img, "board": board, "mask": mask}
  for name, (L, s) in FIELDS.items():
    interp, extrap, train = [], [], []
    for seed in range(seeds):
      model, p, _ = fit(L, s, g, train_img, np.ones_like(mask), steps, seed, width, depth)
      up = np.asarray(model.apply({"params": p}, jnp.asarray(g_up)))
      interp.append(float(np.mean((up - gt_hi) ** 2)))
      train.append(float(np.mean((np.asarray(model.apply({"params": p}, jnp.asarray(g)))
                                  - train_img) ** 2)))
      model, p, _ = fit(L, s, g, board, mask, steps, seed, width, depth)
      pred = np.asarray(model.apply({"params": p}, jnp.asarray(g)))
      extrap.append(float(np.mean((pred[~mask] - board[~mask]) ** 2)))
      if seed == 0:
        images[f"{name}_interp"], images[f"{name}_extrap"] = up, pred
    res["interp_mse"][name] = float(np.mean(interp))
    res["extrap_mse"][name] = float(np.mean(extrap))
    res["train_mse"][name] = float(np.mean(train))
    res["per_seed"][name] = {"interp_mse": interp, "extrap_mse": extrap, "train_mse": train}
  res["setup"] = {"steps": steps, "seeds": seeds, "width": width, "depth": depth,
                  "fields": {k: {"L": v[0], "scale": v[1]} for k, v in FIELDS.items()},
                  "pixels_per_unit": unit, "square": CHECK, "corner": CORNER}
  return res, images


def figure(images, path):
  nearest = np.repeat(np.repeat(images["train"], UP, 0), UP, 1)
  masked = np.where(images["mask"][..., None], images["board"], 0.5)
  rows = [("(a) interpolation 64 -> 256", [images["gt_hi"], nearest, images["lo_interp"],
                                            images["hi_interp"]],
           ["ground truth 256", "training 64 (nearest)", "Lo L=5 s=5", "Hi L=10 s=5"]),
          ("(b) extrapolation", [images["board"], masked, images["lo_extrap"],
                                 images["hi_extrap"]],
           ["checkerboard", "training (corner masked)", "Lo L=5 s=5", "Hi L=10 s=5"])]
  fig, axes = plt.subplots(2, 4, figsize=(12, 6.4))
  for r, (title, ims, names) in enumerate(rows):
    for c, (im, n) in enumerate(zip(ims, names)):
      axes[r, c].imshow(np.clip(im, 0, 1), interpolation="nearest")
      axes[r, c].set_title(n, fontsize=9)
      axes[r, c].axis("off")
    axes[r, 0].text(-0.1, 0.5, title, transform=axes[r, 0].transAxes, rotation=90,
                    va="center", ha="right", fontsize=9)
  fig.tight_layout()
  fig.savefig(path, dpi=100)


def record_path(steps: int, seeds: int, unit: float) -> str:
  """results/toy2d.json for the paper-size setting, results/toy2d_<setting>.json else."""
  if (steps, seeds, unit) == (3000, 3, 32.0):
    return RECORD
  return RECORD.replace(".json", f"_unit{unit:g}_steps{steps}_seeds{seeds}.json")


def _table(record) -> list:
  u = record["setup"]
  agree = {k: all((lo < hi) == (record[k]["lo"] < record[k]["hi"]) for lo, hi in
                  zip(record["per_seed"]["lo"][k], record["per_seed"]["hi"][k]))
           for k in ("interp_mse", "extrap_mse", "train_mse")}

  def row(label, key):
    lo, hi = record[key]["lo"], record[key]["hi"]
    cell = lambda x, best: f"**{x:.5f}**" if best else f"{x:.5f}"  # noqa: E731
    seeds = "yes" if agree[key] else "no"
    return f"| {label} | {cell(lo, lo < hi)} | {cell(hi, hi < lo)} | {seeds} |"
  lo, hi = u["fields"]["lo"], u["fields"]["hi"]
  p = record["provenance"]
  return [f"**{u['pixels_per_unit']:g} training pixels per unit**, {u['width']}x{u['depth']} "
          f"MLPs, {u['steps']} full-batch Adam steps, mean over {u['seeds']} seed(s); "
          f"computed {p.get('time_utc', '?')[:10]} at "
          f"{(p.get('git', {}).get('commit') or '?')[:7]} on {p.get('cpu', {}).get('model', '?')} "
          f"(jax {p.get('versions', {}).get('jax', '?')}).", "",
          f"| MSE | Lo (L={lo['L']}, s={lo['scale']:g}) | Hi (L={hi['L']}, s={hi['scale']:g}) "
          "| every seed agrees |", "|---|---|---|---|",
          row("(a) interpolation to 256x256", "interp_mse"),
          row("(b) extrapolation into the masked corner", "extrap_mse"),
          row("(fit on the 64x64 training image of (a))", "train_mse"), ""]


def page(records) -> str:
  """docs/results/toy2d.md from the records {path: record}, the paper-size
  setting first: mean MSE over seeds, the lower bold."""
  out = ["# The 2D toy (paper fig. 2): low- against high-frequency fields", "",
         "Generated by `python -m experiments.toy2d --record` (each setting's own "
         "`results/toy2d*.json`; what the toy does: "
         "[frequency.md](../frequency.md#choosing-the-frequency-criterion-pairs-calibration-sweeps-2d-toy)).",
         ""]
  for path in sorted(records, key=lambda k: (k != RECORD, k)):
    out += [f"[{os.path.relpath(path, REPO)}](../../{os.path.relpath(path, REPO)}):", ""]
    out += _table(records[path])
  return "\n".join(out + ["![2D toy: interpolation and extrapolation, the paper-size "
                           "setting](../images/toy2d.png)", ""])


def records() -> dict:
  out = {}
  for path in sorted(glob.glob(RECORD.replace(".json", "*.json"))):
    with open(path) as f:
      out[path] = json.load(f)
  return out


def define_flags():
  """The tool's flags, defined on launch (tests import this module beside others)."""
  flags.DEFINE_string("workdir", None, "Output folder (with neither --record nor --report_only).")
  flags.DEFINE_bool("record", False, "Keep the figures and the picture in the repository.")
  flags.DEFINE_bool("report_only", False, "Run nothing: write the page from the kept record.")
  flags.DEFINE_integer("steps", 3000, "Adam steps per fit (full batch).")
  flags.DEFINE_integer("seeds", 3, "Fits per field and task (different initialisations).")
  flags.DEFINE_integer("width", 128, "MLP width.")
  flags.DEFINE_integer("depth", 4, "MLP depth.")
  flags.DEFINE_float("unit", 32.0, "Training pixels per coordinate unit (32: the 64x64 image "
                     "spans [-1, 1]; 1: pixel coordinates).")


def main(argv):
  del argv
  if not FLAGS.report_only:
    if not (FLAGS.workdir or FLAGS.record):
      raise app.UsageError("--workdir=DIR, or --record to keep the figures in the repository")
    res, images = run(FLAGS.steps, FLAGS.seeds, FLAGS.width, FLAGS.depth, FLAGS.unit)
    for key in ("interp_mse", "extrap_mse", "train_mse"):
      print(f"{key:11} lo {res[key]['lo']:.5f}  hi {res[key]['hi']:.5f}")
    record = dict(res, provenance=git_state.collect(measure_peak=False))
    if FLAGS.workdir:
      os.makedirs(FLAGS.workdir, exist_ok=True)
      with open(os.path.join(FLAGS.workdir, "results.json"), "w") as f:
        json.dump(record, f, indent=1)
      figure(images, os.path.join(FLAGS.workdir, "toy2d.png"))
    if FLAGS.record:
      path = record_path(FLAGS.steps, FLAGS.seeds, FLAGS.unit)
      with open(path, "w") as f:
        json.dump(record, f, indent=1)
        f.write("\n")
      if path == RECORD:
        figure(images, IMAGE)
  if FLAGS.record or FLAGS.report_only:
    with open(PAGE, "w") as f:
      f.write(page(records()))
    print("wrote", os.path.relpath(PAGE, REPO))


if __name__ == "__main__":
  define_flags()
  tool.run(sys.modules[__name__], main)
