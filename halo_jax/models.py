"""Flax models: the NeRF MLP and the ray field (a light-field network)."""
from typing import Sequence

import flax.linen as nn
import jax
import jax.numpy as jnp

from halo_jax import encoding


class MLP(nn.Module):
  """ReLU MLP with the input concatenated back in after the `skips` layers."""
  width: int = 256
  depth: int = 8
  skips: Sequence[int] = (4,)

  @nn.compact
  def __call__(self, x):
    inputs = x
    for i in range(self.depth):
      if i in self.skips and i > 0:
        x = jnp.concatenate([x, inputs], -1)
      x = nn.relu(nn.Dense(self.width, name=f"dense_{i}")(x))
    return x


class NeRFMLP(nn.Module):
  """Radiance field: point (and view direction) -> density and colour.

  Attributes:
    pos_freqs, pos_scale: L and s of the point encoding (Lo or Hi P.E.).
    base_freqs, base_scale: when base_freqs > 0, a second (Lo) P.E. placed
      before the first, so a Hi-NeRF can start as an exact copy of a Lo-NeRF
      (see stages.nerf.transfer_from_lo).
    width, depth, skips: trunk size.
    use_viewdirs: condition colour on the view direction (Hi-NeRF); Lo-NeRF
      leaves it out so its colour is view-independent.
    dir_freqs: L of the direction encoding.
    density_bias: softplus(raw + bias); -1 starts the field nearly empty.
  """
  pos_freqs: int = 10
  pos_scale: float = 1.0
  base_freqs: int = 0
  base_scale: float = 1.0
  width: int = 256
  depth: int = 8
  skips: Sequence[int] = (4,)
  use_viewdirs: bool = True
  dir_freqs: int = 4
  density_bias: float = -1.0

  @nn.compact
  def __call__(self, points, viewdirs=None, density_noise_key=None, density_noise=0.0):
    """Args: points [..., 3]; viewdirs [..., 3] unit or None.

    Returns: sigma [...] >= 0 and rgb [..., 3] in (0, 1).
    """
    x = encoding.positional_encoding(points, self.pos_freqs, self.pos_scale)
    if self.base_freqs > 0:
      x = jnp.concatenate(
          [encoding.positional_encoding(points, self.base_freqs, self.base_scale), x], -1)
    h = MLP(self.width, self.depth, tuple(self.skips), name="trunk")(x)
    raw_sigma = nn.Dense(1, name="density")(h)[..., 0]
    if density_noise_key is not None and density_noise > 0:
      raw_sigma = raw_sigma + density_noise * jax.random.normal(density_noise_key, raw_sigma.shape)
    sigma = nn.softplus(raw_sigma + self.density_bias)
    if self.use_viewdirs:
      feat = nn.Dense(self.width, name="bottleneck")(h)
      d = encoding.positional_encoding(viewdirs, self.dir_freqs, 1.0)
      h = nn.relu(nn.Dense(self.width // 2, name="view")(jnp.concatenate([feat, d], -1)))
    rgb = nn.sigmoid(nn.Dense(3, name="rgb")(h))
    return sigma, rgb


class RayField(nn.Module):
  """Light-field network: a ray (entry point on a sphere, direction) -> depth, opacity.

  Depth is measured along the ray from its sphere entry point and lies in
  [near, far] through `sigmoid * 1.002 - 0.001`, as in the authors' code.
  """
  freqs: int = 10
  scale: float = 32.0
  width: int = 256
  depth: int = 8
  skips: Sequence[int] = (4,)
  near: float = 2.0
  far: float = 6.0

  @nn.compact
  def __call__(self, entry_points, directions):
    """Args: entry_points [..., 3], directions [..., 3]. Returns depth [...], acc [...]."""
    x = jnp.concatenate([
        encoding.positional_encoding(entry_points, self.freqs, self.scale),
        encoding.positional_encoding(directions, self.freqs, self.scale)], -1)
    h = MLP(self.width, self.depth, tuple(self.skips), name="trunk")(x)
    out = nn.Dense(2, name="heads")(h)
    unit = nn.sigmoid(out[..., 0]) * 1.002 - 0.001
    depth = self.near + (self.far - self.near) * unit
    acc = nn.sigmoid(out[..., 1])
    return depth, acc


def nerf_from_config(config, name: str):
  """NeRFMLP of stage `name` ('lo' or 'hi') of a run config.

  With config[name].encoding.with_lo, Lo-NeRF's P.E. (config.lo.encoding) is
  prepended to the stage's own.
  """
  cfg, m = config[name], config[name].model
  base = config.lo.encoding if cfg.encoding.get("with_lo", False) else None
  return NeRFMLP(pos_freqs=cfg.encoding.L, pos_scale=cfg.encoding.scale,
                 base_freqs=base.L if base else 0, base_scale=base.scale if base else 1.0,
                 width=m.width, depth=m.depth, skips=tuple(m.skips),
                 use_viewdirs=m.use_viewdirs, dir_freqs=m.dir_freqs,
                 density_bias=m.density_bias)


def ray_field_from_config(cfg, near, far):
  """RayField from the ray stage config."""
  m = cfg.model
  return RayField(freqs=cfg.encoding.L, scale=cfg.encoding.scale, width=m.width,
                  depth=m.depth, skips=tuple(m.skips), near=near, far=far)
