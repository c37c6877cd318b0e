"""Renders on disk in the layout nerfbaselines' `evaluate` reads, so that an
independent tool can re-score them:

  <out>/info.json            what was rendered, how to score it, provenance
  <out>/color/<view>.png     the render, 8-bit
  <out>/gt-color/<view>.png  the ground truth, 8-bit (composited as in training)
  <out>/depth/<view>.npy     float32 depth along the ray parameter (see info.json)
  <out>/depth-rgb/<view>.png depth through a colour map over [near, far]
  <out>/acc/<view>.png       opacity, 8-bit grey
"""
import json
import os

import numpy as np

from halo_jax import image_files, video

def write(out_dir, names, rgb, gt, depth, acc, near, far, info) -> None:
  """names [V]; rgb, gt [V, H, W, 3] floats in [0, 1]; depth, acc [V, H, W];
  info: the info.json fields beyond the layout's own."""
  for sub in ("color", "gt-color", "depth", "depth-rgb", "acc"):
    os.makedirs(os.path.join(out_dir, sub), exist_ok=True)
  for i, name in enumerate(names):
    image_files.write(os.path.join(out_dir, "color", f"{name}.png"), video.to_uint8(rgb[i]))
    image_files.write(os.path.join(out_dir, "gt-color", f"{name}.png"), video.to_uint8(gt[i]))
    np.save(os.path.join(out_dir, "depth", f"{name}.npy"), np.asarray(depth[i], np.float32))
    image_files.write(os.path.join(out_dir, "depth-rgb", f"{name}.png"),
                video.colorize(depth[i], near, far, mask=np.asarray(acc[i]) > 0.5))
    image_files.write(os.path.join(out_dir, "acc", f"{name}.png"),
                video.to_uint8(np.asarray(acc[i])[..., None].repeat(3, -1)))
  full = {"evaluation_protocol": "nerf",
          "render_dataset_metadata": {"color_space": "srgb", "background_color": None},
          **info}
  with open(os.path.join(out_dir, "info.json"), "w") as f:
    json.dump(full, f, indent=1)
