import numpy as np
import jax
import jax.numpy as jnp

from halo_jax import samplers


def test_stratified_bounds_and_monotone():
  t = samplers.stratified(jax.random.PRNGKey(0), jnp.full((100,), 2.0), 6.0, 16)
  t = np.asarray(t)
  assert t.shape == (100, 17)
  assert np.all(np.diff(t, axis=-1) >= 0)
  np.testing.assert_allclose(t[:, 0], 2.0)
  np.testing.assert_allclose(t[:, -1], 6.0)
  det = np.asarray(samplers.stratified(None, 2.0, 6.0, 4, randomized=False))
  np.testing.assert_allclose(det, [2, 3, 4, 5, 6])


def test_depth_window_clips_and_handles_nan():
  lo, hi = samplers.depth_window(jnp.array([4.0, 2.1, 9.0, jnp.nan]), 2.0, 6.0, 0.3)
  np.testing.assert_allclose(lo, [2.8, 2.0, 4.8, 2.0], rtol=1e-6)
  np.testing.assert_allclose(hi, [5.2, 3.3, 6.0, 6.0], rtol=1e-6)
  lo, hi = samplers.depth_window(jnp.array([4.0]), 2.0, 6.0, 0.3, near_only=True)
  np.testing.assert_allclose([lo[0], hi[0]], [2.8, 6.0], rtol=1e-6)


def test_depth_guided_inside_window():
  d = jnp.array([3.0, 5.5])
  t = np.asarray(samplers.depth_guided(jax.random.PRNGKey(1), d, 2.0, 6.0, 32, 0.1))
  assert np.all(np.diff(t, axis=-1) >= 0)
  np.testing.assert_allclose(t[:, 0], [2.6, 5.1], rtol=1e-6)
  np.testing.assert_allclose(t[:, -1], [3.4, 5.9], rtol=1e-6)


def test_hierarchical_follows_weights():
  edges = jnp.linspace(2.0, 6.0, 9)[None]
  w = jnp.zeros((1, 8)).at[0, 5].set(1.0)  # all mass in [4.5, 5.0]
  t = np.asarray(samplers.hierarchical(jax.random.PRNGKey(0), edges, w, 64))
  assert np.all(np.diff(t) >= 0) and t.min() >= 2.0 and t.max() <= 6.0
  inside = np.mean((t >= 4.5) & (t <= 5.0))
  assert inside > 0.95
  # All-zero weights fall back to uniform over the range.
  t0 = np.asarray(samplers.hierarchical(None, edges, jnp.zeros((1, 8)), 8, randomized=False))
  np.testing.assert_allclose(t0[0], np.linspace(2, 6, 9), atol=1e-3)


def test_with_full_range_tiles_the_range_and_keeps_the_window():
  keys = jax.random.split(jax.random.PRNGKey(3), 4)
  depth = jnp.array([0.1, 0.5, 0.9, 0.0])
  win = samplers.depth_guided(keys, depth, 0.0, 1.0, 15, 0.1)
  edges = samplers.with_full_range(jax.random.PRNGKey(4), win, 0.0, 1.0, 16)
  e = np.asarray(edges)
  assert e.shape == (4, 33)                      # 15 + 16 + 1 intervals
  np.testing.assert_allclose(e[:, 0], 0.0)
  np.testing.assert_allclose(e[:, -1], 1.0)
  assert np.all(np.diff(e, axis=-1) >= 0)
  # every window edge is kept, and the 16 full-range intervals reach outside it
  for r in range(4):
    assert np.all(np.isin(np.asarray(win[r]), e[r]))
    lo, hi = max(0.0, float(depth[r]) - 0.1), min(1.0, float(depth[r]) + 0.1)
    outside = ((e[r] < lo - 1e-6) | (e[r] > hi + 1e-6)).sum()
    assert outside >= 16 * (1.0 - (hi - lo)) - 2
  assert samplers.with_full_range(None, win, 0.0, 1.0, 0) is win
