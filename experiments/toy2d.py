"""The 2D toy of HALO's figure 2: low- vs high-frequency fields on images.

  python -m experiments.toy2d --workdir=DIR [--steps=3000] [--seeds=3]

A field maps a pixel coordinate (in pixels of the 64x64 training grid) through
P.E. gamma(p; L, s) and an MLP to a colour. Lo: L=5, s=5; Hi: L=10, s=5 (the
paper's appendix).
(a) Interpolation: fit a 64x64 image (a 256x256 render of the procedural scene,
    box-filtered by 4) and render 256x256; error against the 256x256 render.
(b) Extrapolation: fit a 64x64 checkerboard (8-pixel squares) with its
    top-right 24x24 corner masked out; error on the masked corner.
Writes DIR/results.json ({"interp_mse": {"lo", "hi"}, "extrap_mse": {"lo", "hi"},
and per-seed values}) and DIR/toy2d.png, and prints the numbers.
"""
import json
import os

from absl import app, flags
import flax.linen as nn
import jax
import jax.numpy as jnp
import matplotlib
import numpy as np
import optax

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # pylint: disable=g-import-not-at-top

from halo_jax import camera, encoding, models  # pylint: disable=g-import-not-at-top
from halo_jax.datasets import procedural

FLAGS = flags.FLAGS
flags.DEFINE_string("workdir", None, "Output folder.")
flags.DEFINE_integer("steps", 3000, "Adam steps per fit (full batch).")
flags.DEFINE_integer("seeds", 3, "Fits per field and task (different initialisations).")
flags.DEFINE_integer("width", 128, "MLP width.")
flags.DEFINE_integer("depth", 4, "MLP depth.")
flags.DEFINE_float("unit", 32.0, "Training pixels per coordinate unit (32: the 64x64 image "
                   "spans [-1, 1]; 1: pixel coordinates).")

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


def main(argv):
  del argv
  os.makedirs(FLAGS.workdir, exist_ok=True)
  res, images = run(FLAGS.steps, FLAGS.seeds, FLAGS.width, FLAGS.depth, FLAGS.unit)
  with open(os.path.join(FLAGS.workdir, "results.json"), "w") as f:
    json.dump(res, f, indent=1)
  figure(images, os.path.join(FLAGS.workdir, "toy2d.png"))
  for key in ("interp_mse", "extrap_mse", "train_mse"):
    print(f"{key:11} lo {res[key]['lo']:.5f}  hi {res[key]['hi']:.5f}")


if __name__ == "__main__":
  flags.mark_flags_as_required(["workdir"])
  app.run(main)
