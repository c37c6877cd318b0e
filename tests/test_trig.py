"""trig.sin_quadrant / sin_cos against float64 numpy, from tiny to huge angles."""
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from halo_jax import trig


def _angles(lo, hi, n=200_000, seed=0):
  rng = np.random.default_rng(seed)
  x = np.exp(rng.uniform(np.log(lo), np.log(hi), n)) * rng.choice([-1.0, 1.0], n)
  return x.astype(np.float32)


@pytest.mark.parametrize("lo,hi,bound", [
    (1e-30, 1.0, 1.5e-7),        # tiny angles: sin x = x to the last bit matters
    (1.0, 1e3, 2e-7),            # a positional encoding's range
    (1e3, 2.0 ** 24, 2.5e-7),    # compensated encodings' large angles
    (2.0 ** 24, 2.0 ** 30, 2e-5),
])
def test_sin_cos_match_float64(lo, hi, bound):
  x = _angles(lo, hi)
  s, c = jax.jit(trig.sin_cos)(jnp.asarray(x))
  x64 = x.astype(np.float64)   # the float32 angle, exactly
  assert np.max(np.abs(np.asarray(s, np.float64) - np.sin(x64))) < bound
  assert np.max(np.abs(np.asarray(c, np.float64) - np.cos(x64))) < bound


def test_quadrants_are_exact_quarter_turns():
  x = _angles(1e-3, 1e4, n=20_000, seed=1)
  q = np.arange(-4, 5, dtype=np.int32)[:, None]
  got = np.asarray(jax.jit(trig.sin_quadrant)(jnp.asarray(x)[None], q), np.float64)
  want = np.sin(x.astype(np.float64)[None] + q * np.pi / 2)
  assert np.max(np.abs(got - want)) < 2e-7


def test_special_values():
  # past 2^30 (float32 spacing 64 and more) NaN, never a value outside [-1, 1]
  x = jnp.asarray([0.0, -0.0, 2.0 ** 30, np.inf, -np.inf, np.nan, 1e20, -3e38], jnp.float32)
  s, c = trig.sin_cos(x)
  assert s[0] == 0 and c[0] == 1 and c[1] == 1
  np.testing.assert_allclose([s[2], c[2]], [np.sin(2.0 ** 30), np.cos(2.0 ** 30)], atol=2e-5)
  assert np.all(np.isnan(np.asarray(s[3:]))) and np.all(np.isnan(np.asarray(c[3:])))


def test_derivatives_are_the_other_function():
  x = jnp.asarray(_angles(1e-2, 1e2, n=1000, seed=2))
  ds = jax.vmap(jax.grad(lambda v: trig.sin_cos(v)[0]))(x)
  dc = jax.vmap(jax.grad(lambda v: trig.sin_cos(v)[1]))(x)
  np.testing.assert_allclose(ds, np.cos(np.asarray(x, np.float64)), atol=2e-7)
  np.testing.assert_allclose(dc, -np.sin(np.asarray(x, np.float64)), atol=2e-7)
  # second derivative through the jvp rule: d2 sin = -sin
  d2 = jax.vmap(jax.grad(jax.grad(lambda v: trig.sin_cos(v)[0])))(x)
  np.testing.assert_allclose(d2, -np.sin(np.asarray(x, np.float64)), atol=2e-7)


def test_xla_reference_arm_agrees():
  x = jnp.asarray(_angles(1e-3, 1e3, n=10_000, seed=3))
  fast = trig.sin_cos_stacked(x)
  ref = jax.jit(trig.sin_cos_stacked, static_argnums=1)(x, "xla")   # XLA's sin and cos
  with pytest.raises(ValueError, match="sin_cos='libm'"):
    trig.sin_cos_stacked(x, "libm")
  np.testing.assert_allclose(fast, ref, atol=2.5e-7)
  np.testing.assert_allclose(ref[0], np.sin(np.asarray(x)), atol=1e-7)


def test_other_dtypes_use_jnp():
  x = jnp.linspace(-10, 10, 101, dtype=jnp.bfloat16)
  s, c = trig.sin_cos(x)
  assert s.dtype == jnp.bfloat16
  np.testing.assert_allclose(np.asarray(s, np.float32), np.sin(np.asarray(x, np.float32)), atol=1e-2)
  np.testing.assert_allclose(np.asarray(c, np.float32), np.cos(np.asarray(x, np.float32)), atol=1e-2)


def test_the_sin_cos_kind_is_part_of_what_a_model_is_traced_for():
  """Two fields that differ only in `sin_cos` lower to different programs
  under one jitted function (no trace of one reused for the other): XLA's
  sine in one, only multiply-adds in the other; their values agree."""
  from halo_jax import models  # pylint: disable=g-import-not-at-top
  make = lambda kind: models.NeRFMLP(pos_freqs=4, width=16, depth=2, skips=(), dir_freqs=2,
                                     sin_cos=kind)
  x = jnp.linspace(-1.0, 1.0, 12).reshape(4, 3)
  params = make("polynomial").init(jax.random.PRNGKey(0), x, x)
  apply = jax.jit(lambda model, p, a: model.apply(p, a, a), static_argnums=0)
  texts = {k: apply.lower(make(k), params, x).as_text() for k in trig.KINDS}
  assert "sine" in texts["xla"] and "sine" not in texts["polynomial"]
  np.testing.assert_allclose(apply(make("xla"), params, x)[1],
                             apply(make("polynomial"), params, x)[1], atol=1e-6)
