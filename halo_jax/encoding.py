"""Input encodings: positional encoding with a frequency count L and a scale s.

Precision. In fp32 the angle 2^k x / s carries a rounding error of about
|angle| * 2^-24 once it is formed, so a naive encoding loses all precision for
large |x| * 2^L / s (0.4 absolute error in sin at |x| = 1e3, L = 16, s = 7).
The sines reduce their argument exactly (halo_jax/trig.py), so the only loss is
in forming the angle. We form it as a1 + b, where a1 = x_hi * f_hi is an exact fp32
product (x and f = 2^k / s split into 12-bit halves) and b is the small rest,
then use sin(a1 + b) = sin a1 cos b + cos a1 sin b. The error is then about
2^-24 * (3 + |angle| * 2^-11) instead of 2^-24 * |angle|; `experiments/
stability.py` measures both against float64. For power-of-two s both forms
are exact up to sin's own rounding.
"""
import enum

import jax
import jax.numpy as jnp
import numpy as np

from halo_jax import trig

def _split_host(values: np.ndarray):
  """float64 [...] -> (hi, lo) float32 with hi holding 12 significant bits."""
  hi = trig.top12_host(values)
  return hi, (values - hi.astype(np.float64)).astype(np.float32)


def _split(x):
  """fp32 x -> (x_hi, x_lo), x_hi with 12 significant bits, x_hi + x_lo == x exactly."""
  hi = trig.top12(x)
  return hi, x - hi


def _by_frequency(x, freqs):
  """x [..., D], freqs [L] (host) -> [..., L * D] = x_d f_k ordered (k, d).

  One matmul with a matrix holding one frequency per column: exact, since
  the other terms are zeros, and a matmul is where XLA stops fusing, so the
  arithmetic that made x (a sampler's) is not redone for every feature of
  the sin/cos pass and the concatenation after it (4x faster on a CPU).
  """
  dim = x.shape[-1]
  matrix = np.zeros((dim, len(freqs) * dim), np.float64)
  for k, f in enumerate(freqs):
    matrix[np.arange(dim), k * dim + np.arange(dim)] = f
  return jnp.matmul(x, jnp.asarray(matrix, x.dtype), precision=jax.lax.Precision.HIGHEST)


def sin_cos_of_scaled(x, freqs: np.ndarray, sin_cos: str = "polynomial"):
  """sin(x f) and cos(x f) [..., 2, L * D] of coordinates x [..., D] at every
  frequency f of freqs [L] (host float64), each half ordered (k, dim). An fp32
  x gets the compensated angle unless every frequency is a power of two;
  other dtypes the direct one. sin_cos: trig.KINDS (static)."""
  freqs = np.asarray(freqs, np.float64)
  powers_of_two = np.all(np.frexp(freqs)[0] == 0.5)
  if x.dtype != jnp.float32 or powers_of_two:
    # x * 2^k is exact in any binary float: no compensation needed.
    return trig.sin_cos_stacked(_by_frequency(x, freqs), sin_cos)
  f_hi, f_lo = _split_host(freqs)
  x_hi, x_lo = _split(x)
  a1 = _by_frequency(x_hi, f_hi)                                  # exact: 12 x 12 bits
  b = _by_frequency(x_lo, f_hi) + _by_frequency(x, f_lo)          # |b| <= |angle| 2^-11
  sb, cb = trig.sin_cos(b, sin_cos)
  # sin(a1 + b) = sin a1 cos b + cos a1 sin b, and the cosine a quarter turn on
  q = np.array([[0], [1]], np.int32)
  a1 = a1[..., None, :]
  return (trig.sin_quadrant(a1, q, sin_cos) * cb[..., None, :]
          + trig.sin_quadrant(a1, q + 1, sin_cos) * sb[..., None, :])


def positional_encoding(x, num_freqs: int, scale: float = 1.0, include_input: bool = True,
                        sin_cos: str = "polynomial"):
  """gamma(x; L, s) = [x / s, sin(2^k x / s), cos(2^k x / s)], k = 0..L-1, of
  x [..., D]: [..., D (2 L + include_input)] features, all sines first, then
  all cosines, each ordered (k, dim). s > 1 lowers every frequency; L = 0
  leaves the input alone (if included). sin_cos: trig.KINDS (static)."""
  freqs = 2.0 ** np.arange(num_freqs, dtype=np.float64) / float(scale)
  both = sin_cos_of_scaled(x, freqs, sin_cos)
  feats = [both.reshape(*both.shape[:-2], -1)]
  if include_input:
    feats = [x / scale] + feats
  return jnp.concatenate(feats, axis=-1)


def over_points(encode, rows):
  """The batch form of a per-point encoding: `encode` (one point [D] -> [E])
  mapped over rows [P, D] with jax.vmap -> [P, E]. The fields encode their
  points through here."""
  return jax.vmap(encode)(rows)


def naive_positional_encoding(x, num_freqs: int, scale: float = 1.0):
  """The uncompensated sin/cos features [..., 2 L D] (for the precision comparison)."""
  angles = (x / scale)[..., None, :] * (2.0 ** jnp.arange(num_freqs, dtype=x.dtype))[:, None]
  angles = angles.reshape(*x.shape[:-1], -1)
  return jnp.concatenate([jnp.sin(angles), jnp.cos(angles)], -1)


def encoded_size(dim: int, num_freqs: int, include_input: bool = True) -> int:
  """Width of positional_encoding's output for a D-dimensional input."""
  return dim * (2 * num_freqs + int(include_input))


class FourierStream(enum.IntEnum):
  """Offsets added to a field's Fourier `seed`, one per encoded input, so
  that no two inputs draw the same frequency matrix."""
  EPI_ST = 0      # EPINeRF's (s', t')
  EPI_THETA = 1   # EPINeRF's theta
  EPI_UV = 2      # EPINeRF's view (u, v)
  RAY_FIELD = 3   # EPIRayField's (u, v, s, t)
  NELF_UV = 4     # NeLFRayField's (u, v)
  NELF_ST = 5     # NeLFRayField's (s, t)


def fourier_matrix(seed: int, dim: int, num_features: int, std: float) -> np.ndarray:
  """A fixed Gaussian frequency matrix B [dim, num_features], B ~ N(0, std^2)
  (Tancik et al.'s random Fourier features), reproducible from `seed`."""
  return (np.random.default_rng(seed).standard_normal((dim, num_features)) * std).astype(
      np.float32)


def fourier_std_from_angular(std: float, span: float) -> float:
  """Our feature std for features written sin(f x), f ~ N(0, std^2) radians
  per unit, over a coordinate that spans `span` units where ours spans 2.

  gaussian_fourier_features uses sin(2 pi B x) with x in [-1, 1] across the
  image (or camera grid): B cycles per unit, 2 B across. Features sin(f x)
  over a span S complete f S / (2 pi) cycles across, so matching cycles gives
  B = f S / (4 pi). (The authors' light-field code: sin(f x), s and t in
  pixels / 1024, S = 1 across the image, so their std 64 is our 5.09.)
  """
  return std * span / (4.0 * np.pi)


def gaussian_fourier_features(x, matrix: np.ndarray, include_input: bool = True,
                              sin_cos: str = "polynomial"):
  """[x, sin(2 pi x B), cos(2 pi x B)]: [..., D * include_input + 2 F] of
  x [..., D] and a fixed host matrix B [D, F] (fourier_matrix)."""
  angles = 2.0 * np.pi * (x @ jnp.asarray(matrix, x.dtype))
  both = trig.sin_cos_stacked(angles, sin_cos)
  feats = [both.reshape(*both.shape[:-2], -1)]
  return jnp.concatenate(([x] if include_input else []) + feats, axis=-1)


def axis_frequencies(seed: int, num_features: int, std: float,
                     num_drawn: int = 0) -> np.ndarray:
  """Sorted |N(0, std^2)| scalar frequencies [num_features] (cycles per unit),
  reproducible from `seed`: the authors' NormalEmbedder draws `num_drawn`
  (default num_features), sorts their magnitudes and may keep the lowest few
  (their colour heads read only the first sin/cos pairs)."""
  drawn = max(num_drawn, num_features)
  freqs = np.abs(np.random.default_rng(seed).standard_normal(drawn) * std)
  return np.sort(freqs)[:num_features].astype(np.float32)


def octave_frequencies(num_features: int, scale: float) -> np.ndarray:
  """The octaves 2^k / scale radians per unit, k = 0..num_features - 1, in
  cycles per unit: the authors' BaseEmbedder (NeRF's positional encoding)
  as axis_fourier_features' frequencies."""
  return (2.0 ** np.arange(num_features) / (2.0 * np.pi * scale)).astype(np.float64)


# Scalar frequencies per kind (config `*_kind`), all read as (seed, count, std
# or scale, count drawn): 'axis' sorted half-normal draws of std `std`,
# 'octaves' 2^k / `std` radians per unit (std is the scale s).
SCALAR_KINDS = {
    "axis": axis_frequencies,
    "octaves": lambda seed, num, scale, drawn=0: octave_frequencies(num, scale),
}


def axis_fourier_features(x, freqs: np.ndarray, include_input: bool = False,
                          sin_cos: str = "polynomial"):
  """Axis-aligned Fourier features: every frequency applied to each coordinate
  on its own (the authors' NormalEmbedder), not to oblique projections.

  Ordered as theirs: for each frequency f_k of freqs [F] (cycles per unit,
  host; axis_frequencies), sin(2 pi f_k x_d) over d, then cos(2 pi f_k x_d)
  over d: [..., D * include_input + 2 F D] of x [..., D] (the authors'
  light-field embedders do not prepend x).
  """
  dim, num = x.shape[-1], len(freqs)
  both = sin_cos_of_scaled(x, 2.0 * np.pi * np.asarray(freqs, np.float64), sin_cos)
  both = jnp.swapaxes(both.reshape(*both.shape[:-1], num, dim), -3, -2)  # [..., F, 2, D]
  feats = both.reshape(*both.shape[:-3], 2 * num * dim)
  return jnp.concatenate([x, feats], -1) if include_input else feats


def fourier_encode(x, kind: str, seed: int, num_features: int, std: float, num_drawn: int = 0,
                   sin_cos: str = "polynomial"):
  """x [..., D] encoded by `kind`: 'gaussian' (gaussian_fourier_features of a
  fourier_matrix, the input prepended) or a SCALAR_KINDS entry
  (axis_fourier_features, no input). Returns [..., E]."""
  if kind == "gaussian":
    return gaussian_fourier_features(x, fourier_matrix(seed, x.shape[-1], num_features, std),
                                     sin_cos=sin_cos)
  if kind not in SCALAR_KINDS:
    raise ValueError(f"encoder kind {kind!r}: use 'gaussian' or one of {sorted(SCALAR_KINDS)}")
  return axis_fourier_features(x, SCALAR_KINDS[kind](seed, num_features, std, num_drawn),
                               sin_cos=sin_cos)
