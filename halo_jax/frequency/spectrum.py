"""The frequency criterion of HALO sec. 4.1: how much a small camera move
changes the 2D spectrum of rendered images.

Definition (the paper leaves the details open; we fix them here so that its
threshold of 25 means something):
  * image scale: grey = mean of R, G, B, in [0, 255] (inputs in [0, 1] are
    clipped to it first, so saturated renders count as 255);
  * FFT normalisation: unitary ("ortho", divided by sqrt(H W)), so by
    Parseval the criterion is on the scale of a pixel difference in grey
    levels and does not grow with resolution;
  * mask: per pair, the DC coefficient and round(mask_fraction H W) more of the
    largest coefficients of (|F(I_a)| + |F(I_b)|) / 2 are dropped; these carry the
    image's overall brightness and dominant low frequencies, which a camera
    move changes the most even when the field is artefact-free;
  * sigma = mean over pairs of the mean |F(I_a) - F(I_b)| over kept
    coefficients.
"""
import jax
import jax.numpy as jnp


def grey_255(images):
  """[..., H, W, 3] in [0, 1] -> [..., H, W] grey levels in [0, 255]."""
  return jnp.clip(images, 0.0, 1.0).mean(-1) * 255.0


def spectrum_mask(spec_a, spec_b, mask_fraction: float):
  """The coefficients [..., H, W] (bool) the criterion keeps of one pair's
  complex spectra spec_a, spec_b [..., H, W]: all but DC and the
  mask_fraction share with the largest mean magnitude."""
  mag = 0.5 * (jnp.abs(spec_a) + jnp.abs(spec_b))
  h, w = mag.shape[-2:]
  num_drop = int(round(mask_fraction * h * w))
  flat = mag.reshape(*mag.shape[:-2], h * w)
  keep = jnp.ones(flat.shape, bool).at[..., 0].set(False)  # DC is index 0
  if num_drop > 0:
    # Rank without DC, so num_drop coefficients besides it are dropped.
    _, top = jax.lax.top_k(flat.at[..., 0].set(-1.0), num_drop)
    keep = keep & ~jnp.any(jnp.arange(h * w) == top[..., :, None], axis=-2)
  return keep.reshape(mag.shape)


def spectrum_difference(images_a, images_b, mask_fraction: float = 0.01):
  """sigma = mean_i mean_kept |F(I_a,i) - F(I_b,i)| of pairs of renders
  images_a, images_b [N, H, W, 3] in [0, 1], beside DC the mask_fraction
  share of the largest coefficients dropped: a scalar in grey levels (0 for
  identical or constant images)."""
  fa = jnp.fft.fft2(grey_255(images_a), norm="ortho")
  fb = jnp.fft.fft2(grey_255(images_b), norm="ortho")
  keep = spectrum_mask(fa, fb, mask_fraction)
  diff = jnp.abs(fa - fb) * keep
  per_pair = diff.sum((-2, -1)) / jnp.maximum(keep.sum((-2, -1)), 1)
  return per_pair.mean()


def area_resize(images, size: int):
  """[..., H, W] -> [..., size, size] by averaging K x K blocks when H and W
  are multiples K of `size` (exact for any integer downscale), else by
  antialiased linear resampling."""
  h, w = images.shape[-2:]
  if h % size == 0 and w % size == 0 and h // size == w // size:
    k = h // size
    return images.reshape(*images.shape[:-2], size, k, size, k).mean((-3, -1))
  return jax.image.resize(images, (*images.shape[:-2], size, size), "linear", antialias=True)


def relative_spectrum_difference(images_a, images_b, mask_fraction: float = 0.01,
                                 size: int = 0):
  """rho = mean over pairs of sum_K |F_a - F_b| / sum_K (|F_a| + |F_b|) / 2.

  The scale-free form of the criterion: the ratio does not change when both
  images are brightened by the same factor or the FFT is normalised another
  way, and with `size` (renders resampled to a fixed criterion resolution) it
  does not depend on the resolution they were rendered at. K is the spectrum
  without DC and without round(mask_fraction size^2) of the largest
  coefficients, as spectrum_mask. 0 for identical renders; 2 |sin(pi k d / N)|
  for a grating of k cycles across N pixels shifted by d pixels (mask 0).

  images_a, images_b: [N, H, W, 3] (or [N, H, W]) pairs of renders, linear in
  brightness (not clipped here, so a brightened pair keeps its ratio); size:
  the criterion resolution (0: the images' own). Returns rho >= 0 (0 where a
  pair's kept spectrum is all zero).
  """
  grey = lambda x: x.mean(-1) if x.ndim == 4 else x
  a, b = grey(jnp.asarray(images_a, jnp.float32)), grey(jnp.asarray(images_b, jnp.float32))
  if size:
    a, b = area_resize(a, size), area_resize(b, size)
  fa, fb = jnp.fft.fft2(a), jnp.fft.fft2(b)
  keep = spectrum_mask(fa, fb, mask_fraction)
  num = (jnp.abs(fa - fb) * keep).sum((-2, -1))
  den = (0.5 * (jnp.abs(fa) + jnp.abs(fb)) * keep).sum((-2, -1))
  return jnp.where(den > 0, num / jnp.maximum(den, 1e-30), 0.0).mean()
