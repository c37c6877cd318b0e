import numpy as np
import jax
import jax.numpy as jnp
import ml_collections

from halo_jax import models, raycast, render


def slab(c, a, b, n):
  """Constant density c on [a, b] split in n intervals; colour red."""
  t = jnp.linspace(a, b, n + 1)
  return jnp.full((n,), c), jnp.tile(jnp.array([[1.0, 0.0, 0.0]]), (n, 1)), t


def test_constant_slab_opacity_and_depth_closed_form():
  c, a, b = 0.7, 2.0, 6.0
  sigma, rgb, t = slab(c, a, b, 4096)
  out = render.volume_render(sigma, rgb, t, white_background=True)
  acc = 1 - np.exp(-c * (b - a))
  np.testing.assert_allclose(out["acc"], acc, rtol=1e-5)
  # E[t] over the slab: int_a^b t c e^{-c (t-a)} dt.
  L = b - a
  depth = a * acc + (1 - np.exp(-c * L) * (1 + c * L)) / c
  np.testing.assert_allclose(out["depth"], depth, rtol=1e-4)
  # Red over white: (1, 1 - acc, 1 - acc).
  np.testing.assert_allclose(out["rgb"], [1.0, 1 - acc, 1 - acc], rtol=1e-5)


def test_weights_exact_for_few_intervals():
  sigma = jnp.array([0.5, 2.0, 1.0])
  t = jnp.array([0.0, 1.0, 1.5, 3.0])
  w, t_last = render.compute_weights(sigma, t)
  d = np.diff(np.asarray(t))
  od = np.asarray(sigma) * d
  T = np.exp(-np.concatenate([[0], np.cumsum(od)[:-1]]))
  np.testing.assert_allclose(w, T * (1 - np.exp(-od)), rtol=1e-6)
  np.testing.assert_allclose(t_last, np.exp(-od.sum()), rtol=1e-6)


def test_opaque_first_interval_and_empty_ray():
  sigma = jnp.array([1e10, 1e10, 0.0])
  t = jnp.array([2.0, 3.0, 4.0, 1e10])
  rgb = jnp.array([[0.2, 0.4, 0.6], [1.0, 1.0, 1.0], [0.0, 0.0, 0.0]])
  out = render.volume_render(sigma, rgb, t)
  np.testing.assert_allclose(out["acc"], 1.0)
  np.testing.assert_allclose(out["rgb"], [0.2, 0.4, 0.6], rtol=1e-6)
  np.testing.assert_allclose(out["depth_max"], 2.5)
  empty = render.volume_render(jnp.zeros(3), rgb, t)
  np.testing.assert_allclose(empty["acc"], 0.0)
  np.testing.assert_allclose(empty["rgb"], [1.0, 1.0, 1.0])
  assert render.normalized_depth(empty["depth"], empty["acc"]) == 0.0


def test_gradients_finite_for_stiff_density():
  t = jnp.array([2.0, 2.0, 3.0, 1e10])  # a zero-length and an "infinite" interval
  g = jax.grad(lambda s: render.volume_render(s, jnp.ones((3, 3)) * 0.5, t)["rgb"].sum())(
      jnp.array([1e10, 1e-3, 5.0]))
  assert np.all(np.isfinite(np.asarray(g)))


def test_rays_rendered_one_by_one_equal_the_batch():
  """render_rays maps per-ray samplers over the batch: ray r of a batch is
  what rendering ray r alone (with its own key) gives."""
  m = models.NeRFMLP(pos_freqs=4, width=16, depth=2, skips=(), use_viewdirs=True)
  params = models.init_nerf(m, "nerf", 0)
  cfg = ml_collections.ConfigDict(dict(kind="hierarchical", num_coarse=8, num_samples=16))
  k_o, k_r = jax.random.split(jax.random.PRNGKey(0))
  o = jnp.array([[0.0, 0.0, 4.0]]) + 0.2 * jax.random.normal(k_o, (5, 3))
  d = jnp.tile(jnp.array([[0.0, 0.0, -1.0]]), (5, 1))
  keys = jax.random.split(k_r, 5)
  kw = dict(near=2.0, far=6.0, white_background=True, randomized=True, noise=0.5)
  batch = raycast.render_rays(m, cfg, params, o, d, keys, **kw)[-1]
  for r in range(5):
    one = raycast.render_rays(m, cfg, params, o[r:r + 1], d[r:r + 1], keys[r:r + 1], **kw)[-1]
    for k in ("rgb", "depth", "acc", "weights"):
      np.testing.assert_allclose(one[k][0], batch[k][r], rtol=1e-5, atol=1e-6)


def test_a_ray_renders_alike_in_any_block_and_chunk():
  """Held-out rendering in blocks (eval.block_rays) and chunks: a ray's render
  agrees whatever its block or chunk holds, to float32 rounding, not to the
  last bit: on the reference CPU a block of 64 rays moves rgb by up to 4e-7
  and depth by 2e-6 against 256, so a change of a method's block size moves
  its fingerprint (docs/notes/2026-11-29-graph-and-records.md)."""
  m = models.NeRFMLP(pos_freqs=4, width=32, depth=2, skips=(), use_viewdirs=False)
  params = models.init_nerf(m, "nerf", 0)
  cfg = ml_collections.ConfigDict(dict(kind="coarse_fine", num_coarse=16, num_samples=32,
                                       coarse_model=False, coarse_weight=1.0, near_only=False,
                                       window=0.3))
  k_o, k_d = jax.random.split(jax.random.PRNGKey(1))
  o = np.asarray(jnp.array([[0.0, 0.0, 4.0]]) + 0.3 * jax.random.normal(k_o, (1000, 3)))
  d = np.asarray(jnp.array([[0.0, 0.0, -1.0]]) + 0.1 * jax.random.normal(k_d, (1000, 3)))
  renders = {}
  for block, chunk in ((256, 512), (64, 512), (64, 384), (16, 1000)):
    fn = raycast.make_eval_fn(m, cfg, near=2.0, far=6.0, white_background=True,
                              block_rays=block)
    renders[block, chunk] = raycast.render_chunked(
        lambda oo, dd, t=None, fn=fn: fn(params, None, oo, dd), o, d, chunk)
  first = renders[256, 512]
  for key, out in renders.items():
    for k, atol in (("rgb", 2e-6), ("acc", 2e-6), ("depth", 2e-5)):
      np.testing.assert_allclose(out[k], first[k], rtol=0, atol=atol, err_msg=f"{key} {k}")
