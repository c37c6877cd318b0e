"""model.compute_dtype: bfloat16 matmuls in the trunk, float32 everywhere a
value is kept (parameters, gradients, outputs), close to the float32 field."""
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from halo_jax import defaults, encoding, models, validate


@pytest.mark.parametrize("use_viewdirs", [True, False])
def test_bfloat16_trunk_stays_close_to_float32_with_float32_state(use_viewdirs):
  kw = dict(width=64, depth=4, skips=(2,), use_viewdirs=use_viewdirs)
  f32, b16 = models.NeRFMLP(**kw), models.NeRFMLP(**kw, compute_dtype="bfloat16")
  params = f32.init(jax.random.PRNGKey(0), jnp.zeros((1, 3)), jnp.zeros((1, 3)))
  # one parameter tree serves both: the dtype changes the arithmetic only
  assert jax.tree_util.tree_structure(params) == jax.tree_util.tree_structure(
      b16.init(jax.random.PRNGKey(0), jnp.zeros((1, 3)), jnp.zeros((1, 3))))
  x = jax.random.normal(jax.random.PRNGKey(1), (128, 8, 3))
  d = jnp.ones((128, 8, 3)) / np.sqrt(3.0)
  s32, c32 = f32.apply(params, x, d)
  s16, c16 = b16.apply(params, x, d)
  assert s16.dtype == c16.dtype == jnp.float32
  # bfloat16 keeps 8 significant bits: ~0.4% per rounding, a few after 4 layers
  assert float(jnp.max(jnp.abs(s16 - s32)) / jnp.max(jnp.abs(s32))) < 0.02
  assert float(jnp.max(jnp.abs(c16 - c32))) < 0.01
  assert float(jnp.max(jnp.abs(c16 - c32))) > 0  # it did compute in bfloat16
  grads = jax.grad(lambda p: b16.apply(p, x, d)[1].sum())(params)
  assert {g.dtype for g in jax.tree_util.tree_leaves(grads)} == {jnp.dtype(jnp.float32)}


def test_float32_default_is_the_plain_field():
  m = models.NeRFMLP(width=32, depth=2, skips=())
  params = m.init(jax.random.PRNGKey(0), jnp.zeros((1, 3)), jnp.zeros((1, 3)))
  x = jax.random.normal(jax.random.PRNGKey(1), (16, 3))
  s, c = m.apply(params, x, x)
  # the same layers by hand, in float32
  p = params["params"]
  h = x
  h = encoding.positional_encoding(x, 10, 1.0)
  for i in range(2):
    h = jax.nn.relu(h @ p["trunk"][f"dense_{i}"]["kernel"] + p["trunk"][f"dense_{i}"]["bias"])
  raw = (h @ p["density"]["kernel"] + p["density"]["bias"])[:, 0]
  np.testing.assert_allclose(s, jax.nn.softplus(raw - 1.0), rtol=1e-5, atol=1e-6)


def test_an_unknown_compute_dtype_is_one_line_naming_the_field():
  c = defaults.base_config()
  c.hi.model.compute_dtype = "float16"
  with pytest.raises(validate.ConfigError, match=r"hi.model.compute_dtype='float16'"):
    validate.validate(c)


def test_a_bfloat16_layer_rounds_its_operands_and_sums_in_float32():
  layer = models.dense(64, "bfloat16", "d")
  x = jax.random.normal(jax.random.PRNGKey(0), (256, 96))
  params = layer.init(jax.random.PRNGKey(1), x)
  y = layer.apply(params, x)
  assert y.dtype == jnp.float32
  # numpy reference: each operand rounded to bfloat16, products and sums in float64
  rounded = lambda a: np.asarray(jnp.asarray(a, jnp.bfloat16).astype(jnp.float32), np.float64)
  p = params["params"]
  want = rounded(x) @ rounded(p["kernel"]) + rounded(p["bias"])
  np.testing.assert_allclose(np.asarray(y), want, rtol=0, atol=1e-4)
  # and it did round: the float32 layer's result is further from the reference
  exact = np.asarray(x, np.float64) @ np.asarray(p["kernel"], np.float64) + np.asarray(p["bias"])
  assert np.max(np.abs(exact - want)) > 10 * np.max(np.abs(np.asarray(y) - want))
