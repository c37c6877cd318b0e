"""experiments/dense_bench.py: its written-out backward and its FLOP count."""
import functools

import jax
import jax.numpy as jnp
import numpy as np

from experiments import dense_bench


def test_split_vjp_gradient_matches_autodiff():
  key = jax.random.PRNGKey(3)
  params = dense_bench.init_params(key, 16)
  x = jax.random.normal(key, (40, dense_bench.IN_FEATURES))
  target = jax.random.normal(jax.random.PRNGKey(4), (40, 4))
  grads = [jax.grad(functools.partial(dense_bench.loss, layer=layer, dtype=jnp.float32))(
      params, x, target) for layer in (dense_bench.dense_relu_xla, dense_bench.dense_relu_split)]
  for a, b in zip(jax.tree.leaves(grads[0]), jax.tree.leaves(grads[1])):
    np.testing.assert_allclose(a, b, rtol=1e-5, atol=1e-6)


def test_flops_count_the_skip_and_the_head():
  # 63->w, 6 of w->w, (w+63)->w at the skip, w->4; forward + 2 backward products
  w, n = 8, 5
  per_point = 63 * w + 6 * w * w + (w + 63) * w + w * 4
  assert dense_bench.mlp_flops(n, w) == 6 * n * per_point
