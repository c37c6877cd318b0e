"""Renders a finished stage along a camera path: colour, depth and opacity videos.

  python -m halo_jax.cli.render --workdir=DIR [--stage=hi] [--path=KIND|FILE] [--frames=60]

Paths (halo_jax/camera_paths.py): an orbit for 360-degree scenes, a spiral for
forward-facing ones, a (u, v) ellipse for light fields, a time sweep at a fixed
camera ('time') and an orbit through time ('orbit_time', the default) for
dynamic scenes, or a file of camera-to-world matrices. Writes
DIR/render/<stage>_<path>_{color,depth,acc}.mp4 (GIF where imageio's ffmpeg
plugin is not installed) and the first colour frame as PNG.
"""
import os

from absl import app, flags
import numpy as np

from halo_jax import camera_paths, evaluate, image_files, restore, video
from halo_jax.cli import launch

FLAGS = flags.FLAGS


def define_flags():
  """The command's flags (defined on launch, not on import, so that both
  commands' functions can be imported together)."""
  flags.DEFINE_string("workdir", None, "A run folder written by halo-train.")
  flags.DEFINE_string("stage", None, "Stage to render (default: the run's output stage).")
  flags.DEFINE_string("path", None, "A path kind (orbit, orbit_time, time, spiral, uv) or a "
                      ".npy / .json file of cameras (default: the scene kind's first).")
  flags.DEFINE_integer("frames", 60, "Frames along a generated path.")
  flags.DEFINE_integer("downscale", 1, "Render at the test views' size divided by this.")
  flags.DEFINE_float("fps", 20.0, "Frames per second.")
  flags.DEFINE_string("out", None, "Output folder (default DIR/render).")
  flags.DEFINE_string("data_root", "", "Scene folder, if not where the run found it.")
  flags.mark_flags_as_required(["workdir"])


def render_path(workdir, stage=None, path=None, frames=60, fps=20.0, out=None,
                data_root="", downscale=1):
  """Renders and writes the videos; returns {'color', 'depth', 'acc': file, 'frames': n}."""
  run = restore.load(workdir, stage, data_root)
  ds = run.dataset
  path = path or ds.facts.path_kinds[0]
  views = camera_paths.views_for(path, ds, frames, downscale)
  r = evaluate.render_views(run.render, views, run.config.eval.chunk,
                            desc=f"render {run.stage} {path}", what="frames")
  out = out or os.path.join(workdir, "render")
  label = os.path.splitext(os.path.basename(path))[0]
  stem = os.path.join(out, f"{run.stage}_{label}")
  seen = r["acc"] > 0.5
  depth = r["depth"]
  lo, hi = (np.percentile(depth[seen], [1, 99]) if seen.any() else (0.0, 1.0))
  written = {
      "color": video.write(stem + "_color", r["rgb"], fps),
      "depth": video.write(stem + "_depth", video.colorize(depth, lo, hi, mask=seen), fps),
      "acc": video.write(stem + "_acc", np.repeat(r["acc"][..., None], 3, -1), fps),
      "frames": len(views.names), "size": (views.height, views.width)}
  image_files.write(stem + "_color_frame0.png", video.to_uint8(r["rgb"][0]))
  return written


def main(argv):
  del argv
  with launch():
    w = render_path(FLAGS.workdir, FLAGS.stage, FLAGS.path, FLAGS.frames, FLAGS.fps,
                    FLAGS.out, FLAGS.data_root, FLAGS.downscale)
  h, wd = w["size"]
  print(f"wrote {w['color']}, {w['depth']}, {w['acc']} ({w['frames']} frames of {wd}x{h})")


def cli():
  """The halo-render console script."""
  define_flags()
  app.run(main)


if __name__ == "__main__":
  cli()
