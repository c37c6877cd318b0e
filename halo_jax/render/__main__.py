"""Renders a trained stage along a camera path, colour and depth side by side.

  python -m halo_jax.render --workdir=DIR [--stage=hi] [--frames=40] [--out=PATH.gif]

For Blender-style scenes the path is the 360-degree orbit at the test views'
elevation and radius. Writes an animated GIF (and the first frame as PNG).
"""
import os

from absl import app, flags, logging
import imageio.v3 as iio
import numpy as np

from halo_jax import camera, checkpoint, datasets, evaluate, geometry, models, raycast
from halo_jax import ray_fields, stages
from halo_jax.stages import base

FLAGS = flags.FLAGS
flags.DEFINE_string("workdir", None, "A run folder written by halo_jax.main.")
flags.DEFINE_string("stage", None, "'hi' or 'lo' (default: the latest finished of hi, lo).")
flags.DEFINE_integer("frames", 40, "Frames along the orbit.")
flags.DEFINE_float("fps", 10.0, "Frames per second of the GIF.")
flags.DEFINE_string("out", None, "Output GIF (default DIR/render/<stage>_orbit.gif).")
flags.mark_flags_as_required(["workdir"])


def _finished(workdir, name):
  return os.path.exists(os.path.join(workdir, name, "final", "config.json"))


def orbit_for(views):
  """Orbit at the mean radius and elevation of `views`' cameras."""
  pos = views.c2w[:, :3, 3]
  radius = float(np.linalg.norm(pos, axis=-1).mean())
  elevation = float(np.rad2deg(np.arcsin(np.clip(pos[:, 2] / np.linalg.norm(pos, axis=-1),
                                                 -1, 1))).mean())
  return radius, elevation


def main(argv):
  del argv
  logging.set_verbosity(logging.WARNING)
  wd = FLAGS.workdir
  name = FLAGS.stage or next((n for n in ("hi", "lo") if _finished(wd, n)), None)
  if name is None or not _finished(wd, name):
    raise SystemExit(f"{wd}: no finished stage {FLAGS.stage or 'hi or lo'} to render")
  config = checkpoint.read_config(os.path.join(wd, name, "final", "config.json"))
  spec = datasets.spec_of(config.data)
  if spec.geometry != geometry.Geometry.SPHERE or spec.dynamic or config[name].sampler.kind == "joint":
    # An orbit is a 360-degree path of a static scene with a separate ray stage.
    raise SystemExit(f"{wd}: orbits are rendered for static 360-degree scenes (no joint "
                     f"sampler); this run is {config.data.kind!r} with sampler "
                     f"{config[name].sampler.kind!r}. "
                     f"Its held-out renders are in {os.path.join(wd, name, 'eval')}.")
  dataset = datasets.load(config.data, wd)
  cfg = config[name]
  model = models.nerf_from_config(config, name)
  state = stages.load(wd, name, base.trainer_of(config, name).params_like(config, name, dataset))
  guide_model, guide_params, radius = None, None, 0.0
  if cfg.sampler.kind == "depth_guided":
    guide_model = ray_fields.ray_field_from_config(config.ray, dataset.near, dataset.far)
    ray_like = base.trainer_of(config, "ray").params_like(config, "ray", dataset)
    guide_params = stages.load(wd, "ray", ray_like).params["ray"]
    radius = config.ray.radius or dataset.radius
  fn = raycast.make_eval_fn(model, cfg.sampler, near=dataset.near, far=dataset.far,
                            white_background=dataset.white_background,
                            guide_model=guide_model, radius=radius,
                            block_rays=config.eval.block_rays)
  cam_radius, elevation = orbit_for(dataset.test)
  h, w, f = dataset.test.height, dataset.test.width, dataset.test.focal
  frames = []
  for c2w in camera.orbit_path(cam_radius, FLAGS.frames, elevation):
    o, d = camera.pixel_rays(c2w, h, w, f)
    out = raycast.render_chunked(lambda oo, dd: fn(state.params["nerf"], guide_params, oo, dd,
                                                   coarse_params=state.params.get("coarse")),
                                 o, d,
                               config.eval.chunk)
    rgb = (np.clip(out["rgb"], 0, 1) * 255).round().astype(np.uint8)
    frames.append(np.concatenate(
        [rgb, evaluate.depth_to_image(out["depth"], dataset.near, dataset.far)], 1))
  out_path = FLAGS.out or os.path.join(wd, "render", f"{name}_orbit.gif")
  os.makedirs(os.path.dirname(os.path.abspath(out_path)), exist_ok=True)
  iio.imwrite(out_path, np.stack(frames), duration=1000.0 / FLAGS.fps, loop=0)
  iio.imwrite(os.path.splitext(out_path)[0] + "_frame0.png", frames[0])
  print(f"wrote {out_path} ({len(frames)} frames of {w}x{h}, colour | depth)")


if __name__ == "__main__":
  app.run(main)
