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


class _Slab:
  """A field with density 50 in the slab lo < z < hi and none elsewhere, grey
  everywhere (the radiance-field call signature raycast.composite uses)."""

  def __init__(self, lo, hi):
    self.lo, self.hi = lo, hi

  def apply(self, variables, pts, vdirs, key=None, noise=0.0, **_):
    z = pts[..., 2]
    sigma = jnp.where((z > self.lo) & (z < self.hi), 50.0, 0.0)
    return sigma, jnp.full(pts.shape, 0.5)


class _FlatDepth:
  """An NDC ray field that predicts depth 0.5 on every ray."""

  def apply(self, variables, origins, dirs):
    return jnp.full(origins.shape[:-1], 0.5), jnp.ones(origins.shape[:-1])


def _render(sampler, field, rays=4, **kw):
  import ml_collections
  from halo_jax import raycast
  from halo_jax.geometry import Geometry
  sc = ml_collections.ConfigDict(dict(kind=sampler, num_samples=16, num_coarse=8, window=0.1,
                                      near_only=False, num_full=0, window_start=0.0,
                                      window_steps=0))
  sc.update(kw)
  o = jnp.zeros((rays, 3))
  d = jnp.broadcast_to(jnp.array([0.0, 0.0, 1.0]), (rays, 3))
  guide = raycast.Guide(_FlatDepth(), {}, Geometry.NDC)
  return raycast.render_rays(field, sc, {}, o, d, jax.random.PRNGKey(0), near=0.0, far=1.0,
                             white_background=False, randomized=False, guide=guide)


def test_full_range_samples_let_the_field_form_a_surface_the_window_misses():
  # the window is [0.4, 0.6]; the surface at [0.8, 0.9] is outside it
  miss = _Slab(0.8, 0.9)
  alone = _render("depth_guided", miss)[-1]
  np.testing.assert_allclose(alone["acc"], 0.0, atol=1e-6)
  # 4 of the 16 intervals over all of [0, 1]: the one [0.75, 1] has its
  # midpoint 0.875 in the slab, so the ray is opaque (1 - exp(-50 * 0.25))
  both = _render("depth_guided", miss, num_full=4)[-1]
  assert both["weights"].shape == (4, 16)
  np.testing.assert_allclose(both["acc"], 1.0 - np.exp(-12.5), rtol=1e-5)
  # a surface inside the window is still found with 11 window intervals
  # instead of 16: 5 and 7 midpoints of 0.018 and 0.0125 in the slab
  hit = _Slab(0.45, 0.55)
  np.testing.assert_allclose(_render("depth_guided", hit, num_full=4)[-1]["acc"],
                             1.0 - np.exp(-50 * 5 * 0.2 / 11), rtol=1e-5)
  np.testing.assert_allclose(_render("depth_guided", hit)[-1]["acc"],
                             1.0 - np.exp(-50 * 8 * 0.2 / 16), rtol=1e-5)


def test_window_fine_pass_resamples_inside_the_window():
  outs = _render("depth_guided_fine", _Slab(0.53, 0.545))
  assert len(outs) == 2
  assert outs[0]["weights"].shape == (4, 8) and outs[1]["weights"].shape == (4, 8 + 16 + 1)  # the union of 9 + 17 edges
  # the coarse pass's 8 intervals of 0.025 see the slab at one midpoint,
  # 0.5375; the fine pass, resampled in [0.525, 0.55], finds its near face
  np.testing.assert_allclose(outs[0]["depth_max"], 0.5375, atol=1e-6)
  np.testing.assert_allclose(outs[1]["depth_max"], 0.531, atol=2e-3)
  # and its opacity: the coarse pass counts the slab as 0.025 long, the
  # fine one close to its 0.015 (1 - exp(-50 * 0.015) = 0.53)
  np.testing.assert_allclose(outs[0]["acc"], 1.0 - np.exp(-50 * 0.025), rtol=1e-5)
  np.testing.assert_allclose(outs[1]["acc"], 1.0 - np.exp(-50 * 0.015), atol=0.03)


def test_window_narrows_linearly_over_its_steps():
  import ml_collections
  sc = ml_collections.ConfigDict(dict(window=0.1, window_start=0.5, window_steps=100))
  got = [float(samplers.window_at(sc, s)) for s in (0, 25, 100, 400)]
  np.testing.assert_allclose(got, [0.5, 0.4, 0.1, 0.1], rtol=1e-6)
  assert samplers.window_at(ml_collections.ConfigDict(dict(window=0.3, window_steps=0)), 7) is None


def test_a_guided_option_on_a_sampler_that_ignores_it_is_refused():
  import pytest
  from conftest import tiny_config
  from halo_jax import datasets, registry
  from halo_jax.stages import radiance
  spec = datasets.spec_of(tiny_config().data)
  for method, field, value, match in (
      ("nerf_tuned", "num_full", 4, r"hi.sampler.num_full=4: only the depth-guided"),
      ("halo", "num_full", 7, r"hi.sampler.num_full=7: must leave"),
      ("nerf_tuned", "window_steps", 10, r"hi.sampler.window_steps=10: only"),
      ("halo", "window_steps", 10, r"hi.sampler.window_start=0.0 with window_steps=10")):
    c = tiny_config(method)
    c.hi.sampler[field] = value
    with pytest.raises(registry.ConfigError, match=match):
      radiance.check(c, "hi", spec)
