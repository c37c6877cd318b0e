import numpy as np
import jax
import jax.numpy as jnp

from halo_jax import camera


def test_centre_pixel_looks_down_minus_z():
  o, d = camera.pixel_rays(np.eye(4), 3, 3, 1.0)
  np.testing.assert_allclose(d[1, 1], [0, 0, -1], atol=1e-7)
  np.testing.assert_allclose(d[0, 2], np.array([1, 1, -1]) / np.sqrt(3), atol=1e-6)


def test_look_at_points_at_target():
  c2w = camera.spherical_camera(4.0, 30.0, 20.0)
  np.testing.assert_allclose(np.linalg.norm(c2w[:3, 3]), 4.0)
  np.testing.assert_allclose(-c2w[:3, 2], -c2w[:3, 3] / 4.0, atol=1e-12)


def test_sphere_entry_same_for_cameras_on_one_line():
  d = jnp.array([[0.0, 0.6, -0.8]])
  for start in (jnp.array([[0.0, -3.0, 4.0]]), jnp.array([[0.0, -1.5, 2.0]])):
    t, p, hit = camera.sphere_entry(start, d, 4.03)
    assert bool(hit[0])
    np.testing.assert_allclose(np.linalg.norm(p[0]), 4.03, rtol=1e-6)
    np.testing.assert_allclose(p[0], start[0] + t[0] * d[0], atol=1e-5)
    if start[0, 1] == -3.0:
      first = p
  np.testing.assert_allclose(p, first, atol=1e-5)


def test_random_hemisphere_rays_look_inward():
  o, d = camera.random_hemisphere_rays(jax.random.PRNGKey(0), 512, 4.0, 1.3)
  np.testing.assert_allclose(np.linalg.norm(o, axis=-1), 4.0, rtol=1e-5)
  np.testing.assert_allclose(np.linalg.norm(d, axis=-1), 1.0, rtol=1e-5)
  assert np.all(np.asarray(o)[:, 2] >= 0)
  assert np.all((np.asarray(o) * np.asarray(d)).sum(-1) < 0)
