"""Held-out evaluation: render views, score PSNR / SSIM, write images and a summary."""
import json
import os

import jax.numpy as jnp
import numpy as np

from halo_jax import image_files, metrics, parallel, progress
from halo_jax import raycast


def depth_to_image(depth, near, far):
  """Depth [H, W] -> uint8 [H, W, 3] grey image, near white, far black."""
  x = 1.0 - np.clip((depth - near) / (far - near), 0.0, 1.0)
  x = np.where(depth > 0, x, 0.0)
  return np.repeat((x * 255).round().astype(np.uint8)[..., None], 3, -1)


def render_views(eval_fn, views, chunk, indices=None, desc="", what="views", leave=True):
  """Renders views (or views[indices]); returns dict of numpy [V, H, W, ...].
  With `desc`, a progress bar counts the views (`what`) and shows rays/s
  (leave=False: it is gone once done)."""
  o, d = views.rays()
  t = views.ray_times()
  if indices is not None:
    o, d = o[indices], d[indices]
    t = None if t is None else t[indices]
  if not desc:
    return raycast.render_chunked(eval_fn, o, d, chunk, t)
  with progress.Render(o.shape[0], what, o.shape[1] * o.shape[2], desc, leave) as bar:
    return raycast.render_chunked(eval_fn, o, d, chunk, t, on_chunk=bar.advance)


def score(rgb, target, with_lpips=False):
  """Per-view metrics: rgb, target [V, H, W, 3] -> {'psnr', 'ssim'[, 'lpips']}: V floats each."""
  rgb = jnp.clip(jnp.asarray(rgb), 0.0, 1.0)
  target = jnp.asarray(target)
  out = {"psnr": [float(x) for x in metrics.psnr(rgb, target)],
         "ssim": [float(x) for x in metrics.ssim(rgb, target)]}
  if with_lpips:  # a VGG pass a view: seconds each on a CPU
    out["lpips"] = [float(metrics.lpips(rgb[i:i + 1], target[i:i + 1])[0])
                    for i in progress.steps(range(rgb.shape[0]), "views", "LPIPS")]
  return out


def heldout(eval_fn, views, chunk, num_views):
  """Mean PSNR over the first `num_views` held-out views (for training curves),
  and the first view's render: {'psnr': float, 'images': {name: [H, W, 3]}}."""
  idx = np.arange(min(num_views, len(views.names)))
  out = render_views(eval_fn, views, chunk, idx, desc="held-out curve", leave=False)
  return {"psnr": float(np.mean(score(out["rgb"], views.images[idx])["psnr"])),
          "images": {views.names[0]: np.asarray(out["rgb"][0])}}


def flicker(eval_fn, views, chunk, num_frames, out_dir=None):
  """Temporal flicker (metrics.temporal_flicker) of a dynamic field at the first
  held-out camera over `num_frames` times evenly spaced in [0, 1].

  Writes <out_dir>/flicker.png (the frames side by side) when out_dir is set.
  """
  o, d = views.rays()
  times = np.linspace(0.0, 1.0, num_frames, dtype=np.float32)
  o = np.broadcast_to(o[:1], (num_frames, *o.shape[1:]))
  d = np.broadcast_to(d[:1], (num_frames, *d.shape[1:]))
  t = np.broadcast_to(times[:, None, None, None], (*o.shape[:3], 1))
  frames = raycast.render_chunked(eval_fn, o, d, chunk, t)["rgb"]
  if out_dir and parallel.is_primary():
    os.makedirs(out_dir, exist_ok=True)
    strip = (np.clip(np.concatenate(list(frames), 1), 0, 1) * 255).round().astype(np.uint8)
    image_files.write(os.path.join(out_dir, "flicker.png"), strip)
  return float(metrics.temporal_flicker(jnp.asarray(frames)))


def evaluate(eval_fn, views, chunk, out_dir, near, far, save_images=True, with_lpips=True,
             desc="evaluate"):
  """Renders every held-out view (a progress bar named `desc`), writes
  <out_dir>/metrics.json (+ images).

  Returns {'psnr', 'ssim'[, 'lpips'], 'num_views', 'per_view': {name: {metric: value}}}.
  """
  out = render_views(eval_fn, views, chunk, desc=desc)
  per_metric = score(out["rgb"], views.images, with_lpips)
  result = {k: float(np.mean(v)) for k, v in per_metric.items()}
  result["num_views"] = len(views.names)
  result["per_view"] = {n: {k: v[i] for k, v in per_metric.items()}
                        for i, n in enumerate(views.names)}
  if not parallel.is_primary():  # one writer per job
    return result
  os.makedirs(out_dir, exist_ok=True)
  with open(os.path.join(out_dir, "metrics.json"), "w") as f:
    json.dump(result, f, indent=1)
  if save_images:
    for i, name in enumerate(views.names):
      rgb = (np.clip(out["rgb"][i], 0, 1) * 255).round().astype(np.uint8)
      gt = (views.images[i] * 255).round().astype(np.uint8)
      dep = depth_to_image(out["depth"][i], near, far)
      image_files.write(os.path.join(out_dir, f"{name}.png"), np.concatenate([gt, rgb, dep], 1))
  return result
