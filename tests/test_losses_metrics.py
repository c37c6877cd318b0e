import numpy as np
import jax.numpy as jnp

from halo_jax import losses, metrics


def test_reconstruction_and_psnr():
  a = jnp.zeros((4, 3))
  b = jnp.full((4, 3), 0.1)
  np.testing.assert_allclose(losses.reconstruction(a, b), 0.01, rtol=1e-6)
  img = jnp.zeros((8, 8, 3))
  np.testing.assert_allclose(metrics.psnr(img + 0.1, img), 20.0, rtol=1e-5)


def test_ray_field_loss_hand_case():
  got = losses.ray_field(jnp.array([3.0, 4.0]), jnp.array([1.0, 0.0]),
                         jnp.array([3.0, 6.0]), jnp.array([0.5, 0.0]), far=6.0)
  np.testing.assert_allclose(got, ((2 / 6) ** 2) / 2 + 0.25 / 2, rtol=1e-6)
  # per-ray weights: the opacity term on the first ray alone (the authors'
  # 360-degree ray field: opacity on training rays, not on random ones)
  first_only = losses.ray_field(jnp.array([3.0, 4.0]), jnp.array([1.0, 0.0]),
                                jnp.array([3.0, 6.0]), jnp.array([0.5, 0.5]), far=6.0,
                                acc_weight=jnp.array([1.0, 0.0]))
  np.testing.assert_allclose(first_only, ((2 / 6) ** 2) / 2 + 0.25 / 2, rtol=1e-6)
  # acc_weight 0: the depth term alone
  depth_only = losses.ray_field(jnp.array([3.0, 4.0]), jnp.array([1.0, 0.0]),
                                jnp.array([3.0, 6.0]), jnp.array([0.5, 0.0]), far=6.0,
                                acc_weight=0.0)
  np.testing.assert_allclose(depth_only, ((2 / 6) ** 2) / 2, rtol=1e-6)


def test_empty_space_only_counts_empty_rays():
  acc = jnp.array([0.9, 0.2, 0.4])
  lo_acc = jnp.array([0.5, 0.001, 0.0])
  np.testing.assert_allclose(losses.empty_space(acc, lo_acc, 0.01), 0.3, rtol=1e-6)
  assert float(losses.empty_space(acc, jnp.ones(3), 0.01)) == 0.0


def test_ssim_identical_is_one_and_noise_lowers_it():
  rng = np.random.default_rng(0)
  img = jnp.asarray(rng.uniform(size=(32, 32, 3)), jnp.float32)
  np.testing.assert_allclose(metrics.ssim(img, img), 1.0, atol=1e-5)
  noisy = jnp.clip(img + 0.2 * rng.normal(size=img.shape), 0, 1)
  assert float(metrics.ssim(noisy, img)) < 0.9
