import numpy as np
import jax.numpy as jnp

from halo_jax import encoding


def test_values_match_numpy_float64():
  x = np.random.default_rng(0).uniform(-4, 4, (7, 3))
  L, s = 5, 32.0
  got = np.asarray(encoding.positional_encoding(jnp.asarray(x, jnp.float32), L, s))
  xs = x / s
  ang = np.concatenate([xs * 2.0 ** k for k in range(L)], -1)
  want = np.concatenate([xs, np.sin(ang), np.cos(ang)], -1)
  assert got.shape == (7, encoding.encoded_size(3, L))
  np.testing.assert_allclose(got, want, atol=2e-6)


def test_known_values_and_no_input():
  # x = pi/2, s = 1: sin(pi/2)=1, sin(pi)=0; cos(pi/2)=0, cos(pi)=-1.
  got = np.asarray(encoding.positional_encoding(jnp.array([[np.pi / 2]]), 2, 1.0, False))
  np.testing.assert_allclose(got, [[1.0, 0.0, 0.0, -1.0]], atol=1e-6)


def test_scale_lowers_frequency():
  # With scale s the highest frequency is 2^(L-1)/s: L=5, s=32 -> period 4 pi.
  x = jnp.array([[0.0], [4 * np.pi]])
  f = np.asarray(encoding.positional_encoding(x, 5, 32.0, False))
  np.testing.assert_allclose(f[0, 4], 0.0, atol=1e-6)   # sin at x=0
  np.testing.assert_allclose(f[1, 4], np.sin(4 * np.pi * 16 / 32), atol=1e-5)
  assert abs(f[1, 4]) < 1e-5 and abs(f[1, 3] - np.sin(4 * np.pi * 8 / 32)) < 1e-5


def test_fourier_std_from_angular_matches_cycles_across_the_image():
  # Features sin(f x) over x = pixel / W (the authors' units, span 1) and ours,
  # sin(2 pi B x') over x' in [-1, 1] with B from the conversion, are the same
  # wave up to a constant phase: their phases differ by a constant per pixel.
  w, f = 256, 40.0
  x_theirs = (np.arange(w) + 0.5) / w
  x_ours = 2.0 * x_theirs - 1.0
  b = encoding.fourier_std_from_angular(f, span=1.0)
  feats = np.asarray(encoding.gaussian_fourier_features(
      jnp.asarray(x_ours[:, None], jnp.float32), np.array([[b]], np.float32), False))
  phase_ours = np.unwrap(np.arctan2(feats[:, 0], feats[:, 1]))
  diff = phase_ours - f * x_theirs
  np.testing.assert_allclose(diff - diff[0], 0.0, atol=1e-3)
  # std 64 in their units is 5.09 in ours; twice the span, twice the std
  np.testing.assert_allclose(encoding.fourier_std_from_angular(64.0, 1.0), 5.093, atol=1e-3)
  assert encoding.fourier_std_from_angular(64.0, 2.0) == 2 * encoding.fourier_std_from_angular(
      64.0, 1.0)
  # the light-field defaults carry the authors' st std 64 converted
  from halo_jax import defaults, light_field_defaults  # pylint: disable=g-import-not-at-top
  np.testing.assert_allclose(light_field_defaults.light_field_stage(defaults.base_config().hi).fourier.st_std,
                             encoding.fourier_std_from_angular(64.0, 1.0), atol=5e-3)
