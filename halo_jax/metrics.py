"""Image quality metrics: PSNR and SSIM (11x11 Gaussian, sigma 1.5, via dm-pix)."""
import dm_pix
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
