"""Frames to files: MP4 through imageio's ffmpeg plugin, GIF without it; colour maps."""
import os

import imageio.v2 as imageio_v2
import matplotlib
import numpy as np

from halo_jax import image_files


def has_ffmpeg() -> bool:
  """Whether imageio-ffmpeg (`pip install 'imageio[ffmpeg]'`, which ships its
  own ffmpeg binary) is installed."""
  try:
    import imageio_ffmpeg  # pylint: disable=g-import-not-at-top
    imageio_ffmpeg.get_ffmpeg_exe()
  except (ImportError, RuntimeError):
    return False
  return True


def to_uint8(x):
  """[..., 3] floats in [0, 1] (or uint8) -> uint8."""
  x = np.asarray(x)
  return x if x.dtype == np.uint8 else (np.clip(x, 0.0, 1.0) * 255).round().astype(np.uint8)


def colorize(values, lo: float, hi: float, cmap: str = "turbo", mask=None):
  """[..., H, W] scalars -> [..., H, W, 3] uint8 through a matplotlib colour map
  over [lo, hi]; pixels where `mask` is False are black."""
  x = np.clip((np.asarray(values, np.float64) - lo) / max(hi - lo, 1e-12), 0.0, 1.0)
  rgb = matplotlib.colormaps[cmap](x)[..., :3]
  if mask is not None:
    rgb = np.where(np.asarray(mask)[..., None], rgb, 0.0)
  return to_uint8(rgb)


def write(path_stem: str, frames, fps: float = 20.0) -> str:
  """Writes frames [F, H, W, 3] as <path_stem>.mp4 (H.264; odd sizes padded by
  one pixel) or, without ffmpeg, <path_stem>.gif; returns the path written."""
  frames = to_uint8(frames)
  os.makedirs(os.path.dirname(os.path.abspath(path_stem)) or ".", exist_ok=True)
  if has_ffmpeg():
    f, h, w, _ = frames.shape
    frames = np.pad(frames, ((0, 0), (0, h % 2), (0, w % 2), (0, 0)), mode="edge")
    path = path_stem + ".mp4"
    with imageio_v2.get_writer(path, format="FFMPEG", fps=fps, codec="libx264",
                               quality=8, macro_block_size=1,
                               ffmpeg_log_level="error") as writer:
      for frame in frames:
        writer.append_data(frame)
    return path
  path = path_stem + ".gif"
  image_files.write(path, frames, duration=1000.0 / fps, loop=0)
  return path
