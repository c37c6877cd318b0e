"""sin and cos of one float32 angle, in elementwise arithmetic that vectorises.

XLA's CPU back end evaluates sin and cos one element at a time (about 10 ns
each on one core, against 0.1 ns for a multiply-add), so the positional
encoding's sines took about as long as the field's matmuls in a render. Here
both come from one argument reduction and two short polynomials: plain
multiplies, adds and selects, which the compiler vectorises on any back end.

Reduction. k = round(x 2/pi), r = x - k pi/2 in [-pi/4, pi/4] (Cody-Waite).
pi/2 is split into three 12-bit parts and a float32 rest, and k into its top
12 bits and the rest, so that every product k_part * c_part is exact and each
subtraction cancels exactly; r then carries about one rounding whatever k is
(checked against float64 up to |x| = 2^30 in tests/test_trig.py). Larger
angles, where float32's spacing is 64 or more, give NaN rather than a value
that only looks like a sine (kind "xla" gives the sine of the float).

How they are evaluated is static: every function takes `kind` (KINDS), and
the models carry it as a field (the config's `sin_cos`), so it is part of
what a jitted function is traced for; no global state is read.
Polynomials: Cephes' minimax sinf/cosf on [-pi/4, pi/4] (about 1 ulp).
"""
import functools

import jax
import jax.numpy as jnp
import numpy as np

_TOP12 = np.uint32(0xFFFFF000)  # sign, exponent and the top 11 stored mantissa bits


def top12_host(v):
  """float32 values (host, any shape) keeping 12 significant bits."""
  return (np.asarray(v, np.float32).view(np.uint32) & _TOP12).view(np.float32)


def _split_half_pi():
  rest, parts = np.pi / 2, []
  for _ in range(3):
    part = float(top12_host(rest))
    parts.append(part)
    rest -= part
  parts.append(float(np.float32(rest)))
  return tuple(parts)


_HALF_PI_PARTS = _split_half_pi()   # sums to pi/2 within float64 precision
_TWO_OVER_PI = np.float32(2.0 / np.pi)
_LARGEST = np.float32(2.0 ** 30)   # the largest |x| reduced (see above)
_SIN_COEFFS = (-1.6666654611e-1, 8.3321608736e-3, -1.9515295891e-4)
_COS_COEFFS = (4.166664568298827e-2, -1.388731625493765e-3, 2.443315711809948e-5)


def top12(x):
  """float32 x keeping 12 significant bits: products of two such are exact."""
  return jax.lax.bitcast_convert_type(
      jax.lax.bitcast_convert_type(x, jnp.uint32) & _TOP12, jnp.float32)


def _reduce(x):
  """x [...] float32 -> (r, k) with x = k pi/2 + r, |r| <~ pi/4, k int32."""
  k = jnp.round(x * _TWO_OVER_PI)
  k_hi = top12(k)
  k_lo = k - k_hi                        # an integer of at most 12 bits
  r = x
  for part in _HALF_PI_PARTS[:3]:
    r = (r - k_hi * part) - k_lo * part  # exact products, exact cancellations
  r = r - k * _HALF_PI_PARTS[3]
  # x 2/pi is rounded before k is, so beyond |x| ~ 1e5 k can be a unit or
  # two off and r up to 2.4 wide: a second, short pass brings it back.
  k2 = jnp.round(r * _TWO_OVER_PI)        # small: its products are exact
  for part in _HALF_PI_PARTS[:3]:        # k2 * the rest is below r's rounding
    r = r - k2 * part
  return r, k.astype(jnp.int32) + k2.astype(jnp.int32)


def _polynomials(r):
  r2 = r * r
  a, b, c = _SIN_COEFFS
  sin_r = r + r * r2 * (a + r2 * (b + r2 * c))
  a, b, c = _COS_COEFFS
  cos_r = 1.0 - 0.5 * r2 + r2 * r2 * (a + r2 * (b + r2 * c))
  return sin_r, cos_r


@jax.jit  # one dispatch when called outside jit (tests, eager code); inlined inside
def _sin_quadrant_f32(x, q):
  r, k = _reduce(x)
  sin_r, cos_r = _polynomials(r)
  k = k + q
  s = jnp.where((k & 1) == 1, cos_r, sin_r)  # odd quadrants: sin(r + pi/2) = cos r
  s = jnp.where((k & 2) == 2, -s, s)         # quadrants 2, 3: the sign flips
  return jnp.where(jnp.abs(x) <= _LARGEST, s, jnp.nan)


# How sin and cos are evaluated (config field `sin_cos`): these polynomials,
# or XLA's own functions (one element at a time on a CPU; fast on a GPU).
# experiments/throughput.py counts FLOPs on the "xla" form (the polynomials'
# multiply-adds are not useful work).
KINDS = ("polynomial", "xla")


def check_kind(kind: str) -> str:
  if kind not in KINDS:
    raise ValueError(f"sin_cos={kind!r}: must be one of {KINDS}")
  return kind


@functools.partial(jax.custom_jvp, nondiff_argnums=(2,))
def sin_quadrant(x, q, kind="polynomial"):
  """sin(x + q pi/2) for float32 x and integer q (broadcast together), the
  quarter turns added exactly: q = 0 gives sin x, q = 1 cos x. Other dtypes,
  and kind "xla", go through jnp.sin / jnp.cos. kind is static (KINDS)."""
  if x.dtype != jnp.float32 or check_kind(kind) == "xla":
    return jnp.where(q % 2 == 0, jnp.sin(x), jnp.cos(x)) * jnp.where(q % 4 < 2, 1.0, -1.0)
  return _sin_quadrant_f32(x, q)


@sin_quadrant.defjvp
def _sin_quadrant_jvp(kind, primals, tangents):
  (x, q), (t, _) = primals, tangents
  return sin_quadrant(x, q, kind), sin_quadrant(x, q + 1, kind) * t


_SIN_COS = np.array([0, 1], np.int32)


def sin_cos_stacked(x, kind="polynomial"):
  """[..., n] -> [..., 2, n]: sin x then cos x as one array, in one elementwise pass."""
  return sin_quadrant(x[..., None, :], _SIN_COS[:, None], kind)


def sin_cos(x, kind="polynomial"):
  """(sin x, cos x), each shaped like x (XLA merges their common reduction)."""
  return sin_quadrant(x, np.int32(0), kind), sin_quadrant(x, np.int32(1), kind)
