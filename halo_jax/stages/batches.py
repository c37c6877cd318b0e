"""Drawing a step's training rays on device, shared by every trainer.

Indices into the flat training rays are drawn uniformly over all pixels of
all views, or (`one_image`) over the pixels of one random view per step, as
the original NeRF does; for the first `precrop_steps` steps only from the
centre crop.
"""
from typing import NamedTuple, Optional

import jax
import jax.numpy as jnp
import numpy as np

from halo_jax.rays import Pixels, Rays
from halo_jax.types import Params


class StageData(NamedTuple):
  """What a radiance or light-field stage's step reads on device: its
  training pixels, each active loss term's prepared arrays under the term's
  name (terms.Term.prepare), and a frozen guide's parameters (or None)."""
  pixels: Pixels
  terms: dict
  guide: Optional[Params] = None


# A pixel is foreground when a channel differs from the background by more.
FOREGROUND_THRESHOLD = 0.05


def pixels_of(views, precrop_frac: Optional[float],
              background: Optional[float] = None) -> Pixels:
  """All pixels of `views` as flat training rays (numpy), with the arrays for
  drawing from the centre crop (index_data) unless precrop_frac is None, and
  from the foreground where a `background` grey level (1.0: white) is given."""
  o, d = views.rays()
  n, h, w = views.images.shape[:3]
  times = views.ray_times()
  rays = Rays(o.reshape(-1, 3), d.reshape(-1, 3),
              None if times is None else np.ascontiguousarray(times.reshape(-1, 1)))
  rgb = views.images.reshape(-1, 3)
  index = None if precrop_frac is None else index_data(n, h, w, precrop_frac)
  if index is not None and background is not None:
    index["fg_idx"] = foreground_pixels(rgb, background)
  return Pixels(rays, rgb, index)


def foreground_pixels(rgb: np.ndarray, background: float) -> np.ndarray:
  """Flat indices [F] of the pixels rgb [R, 3] that are not the background
  colour (every pixel when none is: a scene with no background left)."""
  fg = np.flatnonzero(np.abs(np.asarray(rgb) - background).max(-1) > FOREGROUND_THRESHOLD)
  return (fg if fg.size else np.arange(len(rgb))).astype(np.int32)


def crop_pixels(height: int, width: int, frac: float) -> np.ndarray:
  """Flat pixel indices [P] of the centre crop covering `frac` of each side."""
  dh, dw = int(height * frac / 2), int(width * frac / 2)
  mask = np.zeros((height, width), bool)
  mask[height // 2 - dh:height // 2 + dh, width // 2 - dw:width // 2 + dw] = True
  return np.flatnonzero(mask.reshape(-1)).astype(np.int32)


def index_data(num_views: int, height: int, width: int, precrop_frac: float) -> dict:
  """The arrays `draw` reads: crop_idx [Rc] over all views, crop_pix [P] in
  one view, and the view size."""
  pix = crop_pixels(height, width, precrop_frac)
  per_view = height * width
  crop_idx = (np.arange(num_views, dtype=np.int32)[:, None] * per_view + pix[None]).reshape(-1)
  return {"crop_idx": crop_idx, "crop_pix": pix,
          "view_pixels": np.full((), per_view, np.int32)}


def draw(k_idx, k_crop, step, num_rays: int, batch: int, index, precrop_steps: int,
         one_image: bool = False, fg_steps: int = 0, fg_fraction: float = 0.0):
  """Indices [batch] into the num_rays (static) flat training rays at the
  traced `step`, drawn with keys k_idx (pixels) and k_crop (crop and
  foreground pixels). index: index_data's arrays on device (may be None
  without precrop_steps, one_image and fg_steps; 'fg_idx' for fg_steps).
  precrop_steps: steps drawn from the centre crop only; one_image: each
  step's rays from one random view; for the first fg_steps steps,
  fg_fraction of the batch from the foreground pixels (not pixels_of's
  background), the rest from all pixels.
  """
  if fg_steps > 0:
    idx = draw(k_idx, k_crop, step, num_rays, batch, index, precrop_steps, one_image)
    fg = jnp.asarray(index["fg_idx"])
    idx_fg = fg[jax.random.randint(jax.random.fold_in(k_crop, 2), (batch,), 0, fg.shape[0])]
    take = (jnp.arange(batch) < round(fg_fraction * batch)) & (step < fg_steps)
    return jnp.where(take, idx_fg, idx)
  if precrop_steps <= 0 and not one_image:
    return jax.random.randint(k_idx, (batch,), 0, num_rays)
  if one_image:
    per_view = index["view_pixels"]
    view = jax.random.randint(jax.random.fold_in(k_idx, 1), (), 0, num_rays // per_view)
    idx = view * per_view + jax.random.randint(k_idx, (batch,), 0, per_view)
    pix = index["crop_pix"]
    idx_crop = view * per_view + pix[jax.random.randint(k_crop, (batch,), 0, pix.shape[0])]
  else:
    idx = jax.random.randint(k_idx, (batch,), 0, num_rays)
    crop = index["crop_idx"]
    idx_crop = crop[jax.random.randint(k_crop, (batch,), 0, crop.shape[0])]
  if precrop_steps > 0:
    idx = jnp.where(step < precrop_steps, idx_crop, idx)
  return idx
