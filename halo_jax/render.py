"""Volume rendering along rays (NeRF eq. 1), stable for stiff densities.

The render command (videos along a camera path) is `halo_jax/cli/render.py`.
"""

import jax.numpy as jnp

# An infinite interval (t_edges ending in inf) is taken to be this long, NeRF's
# stand-in for "to infinity": long enough that any density fills it.
INFINITE_DELTA = 1e10


def compute_weights(sigma, t_edges):
  """Per-interval compositing weights.

  w_k = T_k (1 - exp(-sigma_k delta_k)) with T_k = exp(-sum_{j<k} sigma_j delta_j).
  Transmittance is an exponential of an exclusive cumulative sum, never a
  product of (1 - alpha): the product underflows and loses all precision once
  alpha rounds to 1, the sum does not.

  sigma [..., N] >= 0, one per interval of sorted t_edges [..., N + 1]
  (intervals may be 0 long, as long as 1e10, or infinite: an inf edge) ->
  weights [..., N] and the transmittance after the last interval [...].
  """
  delta = interval_lengths(t_edges)
  # sigma * delta can be 0 * inf-like; clamp so it never becomes NaN or inf.
  optical_depth = jnp.clip(sigma * delta, 0.0, 1e30)
  cum = jnp.cumsum(optical_depth, axis=-1)
  excl = jnp.concatenate([jnp.zeros_like(cum[..., :1]), cum[..., :-1]], axis=-1)
  trans = jnp.exp(-excl)
  alpha = -jnp.expm1(-optical_depth)
  return trans * alpha, jnp.exp(-cum[..., -1])


def interval_lengths(t_edges):
  """[..., N + 1] edges -> [..., N] lengths; an infinite one becomes INFINITE_DELTA."""
  delta = jnp.diff(t_edges, axis=-1)
  return jnp.where(jnp.isposinf(delta), INFINITE_DELTA, delta)


def interval_midpoints(t_edges):
  """[..., N + 1] edges -> [..., N] midpoints, finite for an infinite last interval."""
  return t_edges[..., :-1] + 0.5 * interval_lengths(t_edges)


def volume_render(sigma, rgb, t_edges, white_background: bool = True):
  """Composites colours rgb [..., N, 3] in [0, 1] with densities sigma
  [..., N] over t_edges [..., N + 1] (distances along unit-norm rays), onto
  white (C + 1 - acc) with white_background. Returns {rgb [..., 3], depth
  [...] (expected, sum w t_mid; 0 where empty), depth_max [...] (t_mid of the
  largest weight), acc [...] (opacity), weights [..., N]}.
  """
  weights, _ = compute_weights(sigma, t_edges)
  t_mid = interval_midpoints(t_edges)
  acc = weights.sum(-1)
  color = (weights[..., None] * rgb).sum(-2)
  if white_background:
    color = color + (1.0 - acc[..., None])
  depth = (weights * t_mid).sum(-1)
  depth_max = jnp.take_along_axis(t_mid, jnp.argmax(weights, -1)[..., None], -1)[..., 0]
  return {"rgb": color, "depth": depth, "depth_max": depth_max, "acc": acc,
          "weights": weights}


# The authors' last interval: the light that reaches the last sample stops
# there wherever its density is above 0.
OPEN_END_DELTA = 2e10


def open_end_max_depth(weights, sigma, t_edges):
  """t_mid of the largest weight with the last interval OPEN_END_DELTA long,
  [...]: the authors' depth target (argmax of their weights). Where the last
  sample's density is 0 and so every weight is (an empty ray under a ReLU
  density), argmax gives the first sample.

  weights [..., N] (volume_render's), sigma [..., N], t_edges [..., N + 1].
  """
  reaching_last = jnp.clip(1.0 - weights[..., :-1].sum(-1), 0.0, 1.0)
  last = reaching_last * -jnp.expm1(-jnp.clip(sigma[..., -1] * OPEN_END_DELTA, 0.0, 1e30))
  opened = jnp.concatenate([weights[..., :-1], last[..., None]], -1)
  t_mid = interval_midpoints(t_edges)
  return jnp.take_along_axis(t_mid, jnp.argmax(opened, -1)[..., None], -1)[..., 0]


def normalized_depth(depth, acc, eps=1e-10):
  """Expected depth of the visible part, sum w t / sum w, [...]; 0 where acc = 0."""
  return jnp.where(acc > eps, depth / jnp.maximum(acc, eps), 0.0)

