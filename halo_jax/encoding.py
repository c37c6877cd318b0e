"""Input encodings: positional encoding with a frequency count L and a scale s."""
import jax.numpy as jnp


def positional_encoding(x, num_freqs: int, scale: float = 1.0, include_input: bool = True):
  """gamma(x; L, s) = [x, sin(2^k x / s), cos(2^k x / s)] for k = 0..L-1.

  The features are ordered (k, dim) with all sines first, then all cosines.
  Multiplying x/s by 2^k is exact in floating point, so the only rounding comes
  from x / s and from sin/cos themselves.

  Args:
    x: [..., D] coordinates.
    num_freqs: L, the number of octaves (0 gives only the input, if included).
    scale: s, every input is divided by s before encoding (s > 1 lowers all
      frequencies).
    include_input: prepend x / s to the features.

  Returns:
    [..., D * (2 L + include_input)] features.
  """
  xs = x / scale
  freqs = 2.0 ** jnp.arange(num_freqs, dtype=x.dtype)
  angles = (xs[..., None, :] * freqs[:, None]).reshape(*x.shape[:-1], -1)
  feats = [jnp.sin(angles), jnp.cos(angles)]
  if include_input:
    feats = [xs] + feats
  return jnp.concatenate(feats, axis=-1)


def encoded_size(dim: int, num_freqs: int, include_input: bool = True) -> int:
  """Width of positional_encoding's output for a D-dimensional input."""
  return dim * (2 * num_freqs + int(include_input))
