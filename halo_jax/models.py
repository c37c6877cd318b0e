"""Flax models: the NeRF MLP and the ray field (a light-field network)."""
from typing import Sequence

import flax.linen as nn
import jax.numpy as jnp
import numpy as np

from halo_jax import encoding, rng


def _rows(x):
  """x [..., C] as rows [N, C]. The fields run their layers on rows: XLA's CPU
  matmul is about twice as fast on [N, C] x [C, D] as on a [R, S, C] input,
  whose weight gradient contracts two axes."""
  return x.reshape(-1, x.shape[-1])


def _density(h, noise_key, noise, bias, shape):
  """The density head of a radiance field (call inside a compact module):
  softplus(Dense(h) + noise + bias) for rows h [N, W] of points of `shape`
  (N = prod(shape)); returns [N]. Noise only when a key (one, or per ray:
  halo_jax.rng, drawn over `shape` so each ray draws its own) is given."""
  raw = nn.Dense(1, name="density")(h)[..., 0]
  if noise_key is not None and noise > 0:
    raw = raw + noise * rng.normal(noise_key, shape).reshape(raw.shape)
  return nn.softplus(raw + bias)


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
    shape = points.shape[:-1]
    points = _rows(points)
    x = encoding.positional_encoding(points, self.pos_freqs, self.pos_scale)
    if self.base_freqs > 0:
      x = jnp.concatenate(
          [encoding.positional_encoding(points, self.base_freqs, self.base_scale), x], -1)
    h = MLP(self.width, self.depth, tuple(self.skips), name="trunk")(x)
    sigma = _density(h, density_noise_key, density_noise, self.density_bias, shape)
    if self.use_viewdirs:
      feat = nn.Dense(self.width, name="bottleneck")(h)
      viewdirs = _rows(jnp.broadcast_to(viewdirs, (*shape, viewdirs.shape[-1])))
      d = encoding.positional_encoding(viewdirs, self.dir_freqs, 1.0)
      h = nn.relu(nn.Dense(self.width // 2, name="view")(jnp.concatenate([feat, d], -1)))
    rgb = nn.sigmoid(nn.Dense(3, name="rgb")(h))
    return sigma.reshape(shape), rgb.reshape(*shape, 3)


class DeformNeRF(nn.Module):
  """Dynamic radiance field (D-NeRF style): a deformation MLP maps a point at
  time t to a canonical point, which a static NeRFMLP colours.

  x' = x + D(gamma(x), gamma_t(t)), then sigma, rgb = NeRF(x'). D's output
  layer starts at zero, so the field starts static. With base_freqs > 0 the
  Lo encodings of x and t come first in D's input and in the canonical
  NeRF's (as in NeRFMLP), so a Hi model can start as a copy of a Lo model.

  Attributes:
    time_freqs, time_scale: L and s of the time encoding (its own frequencies).
    base_time_freqs, base_time_scale: the Lo time encoding, with base_freqs.
    deform_width, deform_depth: size of the deformation MLP.
    Others as in NeRFMLP.
  """
  pos_freqs: int = 10
  pos_scale: float = 1.0
  base_freqs: int = 0
  base_scale: float = 1.0
  time_freqs: int = 6
  time_scale: float = 1.0
  base_time_freqs: int = 0
  base_time_scale: float = 1.0
  width: int = 256
  depth: int = 8
  skips: Sequence[int] = (4,)
  use_viewdirs: bool = True
  dir_freqs: int = 4
  density_bias: float = -1.0
  deform_width: int = 128
  deform_depth: int = 4

  @nn.compact
  def __call__(self, points, viewdirs=None, density_noise_key=None, density_noise=0.0,
               times=None):
    """Args: points [..., 3]; viewdirs [..., 3] or None; times [..., 1] in [0, 1].

    Returns: sigma [...] >= 0 and rgb [..., 3] in (0, 1).
    """
    if times is None:
      raise ValueError("DeformNeRF needs times [..., 1] (a dynamic scene)")
    shape = points.shape[:-1]
    x, times = _rows(points), _rows(jnp.broadcast_to(times, (*shape, 1)))
    feats = [encoding.positional_encoding(x, self.pos_freqs, self.pos_scale),
             encoding.positional_encoding(times, self.time_freqs, self.time_scale)]
    if self.base_freqs > 0:
      feats = [encoding.positional_encoding(x, self.base_freqs, self.base_scale),
               encoding.positional_encoding(times, self.base_time_freqs,
                                            self.base_time_scale)] + feats
    h = MLP(self.deform_width, self.deform_depth, (), name="deform")(jnp.concatenate(feats, -1))
    offset = nn.Dense(3, kernel_init=nn.initializers.zeros, name="offset")(h).reshape(*shape, 3)
    canonical = NeRFMLP(self.pos_freqs, self.pos_scale, self.base_freqs, self.base_scale,
                        self.width, self.depth, tuple(self.skips), self.use_viewdirs,
                        self.dir_freqs, self.density_bias, name="canonical")
    return canonical(points + offset, viewdirs, density_noise_key, density_noise)


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
    shape = entry_points.shape[:-1]
    x = jnp.concatenate([
        encoding.positional_encoding(_rows(entry_points), self.freqs, self.scale),
        encoding.positional_encoding(_rows(directions), self.freqs, self.scale)], -1)
    h = MLP(self.width, self.depth, tuple(self.skips), name="trunk")(x)
    out = nn.Dense(2, name="heads")(h).reshape(*shape, 2)
    unit = nn.sigmoid(out[..., 0]) * 1.002 - 0.001
    depth = self.near + (self.far - self.near) * unit
    acc = nn.sigmoid(out[..., 1])
    return depth, acc


class EPINeRF(nn.Module):
  """Radiance field of a two-plane light field in EPI coordinates (SPEC sec. 4).

  Points are (s', t', theta): the image-plane position aligned to the central
  view and the EPI angle; the view input is the camera-plane (u, v). Inputs
  are encoded with Gaussian Fourier features: s', t' with std `st_std`,
  theta with `theta_std`, u, v with `uv_std` (counts `*_features`, fixed
  matrices from `seed`).
  """
  st_std: float = 64.0
  st_features: int = 10
  theta_std: float = 8.0
  theta_features: int = 5
  uv_std: float = 1.0
  uv_features: int = 4
  seed: int = 0
  width: int = 256
  depth: int = 8
  skips: Sequence[int] = (4,)
  density_bias: float = -1.0

  @nn.compact
  def __call__(self, points, viewdirs, density_noise_key=None, density_noise=0.0):
    """Args: points [..., 3] (s', t', theta); viewdirs [..., 2] (u, v).

    Returns: sigma [...] >= 0 and rgb [..., 3] in (0, 1).
    """
    shape = points.shape[:-1]
    points, viewdirs = _rows(points), _rows(jnp.broadcast_to(viewdirs, (*shape, 2)))
    x = jnp.concatenate([
        encoding.gaussian_fourier_features(
            points[..., :2], encoding.fourier_matrix(self.seed, 2, self.st_features, self.st_std)),
        encoding.gaussian_fourier_features(
            points[..., 2:], encoding.fourier_matrix(self.seed + 1, 1, self.theta_features,
                                                     self.theta_std))], -1)
    h = MLP(self.width, self.depth, tuple(self.skips), name="trunk")(x)
    sigma = _density(h, density_noise_key, density_noise, self.density_bias, shape)
    v = encoding.gaussian_fourier_features(
        viewdirs, encoding.fourier_matrix(self.seed + 2, 2, self.uv_features, self.uv_std))
    feat = nn.Dense(self.width, name="bottleneck")(h)
    h = nn.relu(nn.Dense(self.width // 2, name="view")(jnp.concatenate([feat, v], -1)))
    rgb = nn.sigmoid(nn.Dense(3, name="rgb")(h))
    return sigma.reshape(shape), rgb.reshape(*shape, 3)


def ray_field_matrix(seed: int, num_features: int, std: float, uv_std: float = 0.0):
  """EPIRayField's frequency matrix B [4 (u, v, s, t), F]: N(0, std^2), the
  (u, v) rows N(0, uv_std^2) where uv_std is not 0 (the same draw, rescaled)."""
  matrix = encoding.fourier_matrix(seed + 3, 4, num_features, std)
  if uv_std:
    matrix = matrix * np.array([[uv_std / std]] * 2 + [[1.0]] * 2, np.float32)
  return matrix


class EPIRayField(nn.Module):
  """Two-plane ray field: (u, v, s, t) -> tau_ray in [0, 1], the ray's depth
  as a fraction of the EPI angle range (tau = (theta - theta_n) / (theta_f - theta_n)).

  Gaussian Fourier features of std `std`, for (u, v) `uv_std` where it is
  not 0: low across the camera plane, where held-out views lie (the knights
  configs: the authors' 0.17 for (u, v), 5.09 for (s, t)).

  With `color`, a second head on the same trunk predicts the ray's colour
  (one hidden layer that also reads the raw (u, v), as the radiance field's
  colour does): the authors' light-field ray field has one, trained on the
  pixels, so the trunk the angle head reads also learns the image.
  """
  std: float = 1.0
  num_features: int = 16
  seed: int = 0
  width: int = 128
  depth: int = 4
  skips: Sequence[int] = ()
  uv_std: float = 0.0
  color: bool = False

  @nn.compact
  def __call__(self, rays):
    """Args: rays [..., 4] (u, v, s, t). Returns tau [...], or with `color`
    (tau [...], rgb [..., 3])."""
    rows = _rows(rays)
    matrix = ray_field_matrix(self.seed, self.num_features, self.std, self.uv_std)
    x = encoding.gaussian_fourier_features(rows, matrix)
    h = MLP(self.width, self.depth, tuple(self.skips), name="trunk")(x)
    tau = nn.sigmoid(nn.Dense(1, name="head")(h)[..., 0]) * 1.002 - 0.001
    tau = tau.reshape(rays.shape[:-1])
    if not self.color:
      return tau
    c = nn.relu(nn.Dense(self.width, name="color_hidden")(
        jnp.concatenate([h, rows[:, :2]], -1)))
    rgb = nn.sigmoid(nn.Dense(3, name="color")(c)) * 1.002 - 0.001
    return tau, rgb.reshape(*rays.shape[:-1], 3)


def nerf_from_config(config, name: str):
  """The radiance field of stage `name` ('lo' or 'hi') of a run config:
  NeRFMLP, or DeformNeRF where config[name].model.kind == 'deform'.

  With config[name].encoding.with_lo, Lo-NeRF's P.E. (config.lo.encoding) is
  prepended to the stage's own.
  """
  cfg, m = config[name], config[name].model
  base = config.lo.encoding if cfg.encoding.get("with_lo", False) else None
  common = dict(pos_freqs=cfg.encoding.L, pos_scale=cfg.encoding.scale,
                base_freqs=base.L if base else 0, base_scale=base.scale if base else 1.0,
                width=m.width, depth=m.depth, skips=tuple(m.skips),
                use_viewdirs=m.use_viewdirs, dir_freqs=m.dir_freqs,
                density_bias=m.density_bias)
  kind = m.get("kind", "nerf")
  if kind == "nerf":
    return NeRFMLP(**common)
  if kind == "epi":
    f = cfg.fourier
    return EPINeRF(st_std=f.st_std, st_features=f.st_features, theta_std=f.theta_std,
                   theta_features=f.theta_features, uv_std=f.uv_std,
                   uv_features=f.uv_features, seed=f.seed, width=m.width, depth=m.depth,
                   skips=tuple(m.skips), density_bias=m.density_bias)
  if kind != "deform":
    raise ValueError(f"{name}.model.kind={kind!r} is not one of 'nerf', 'deform', 'epi'")
  return DeformNeRF(**common, time_freqs=cfg.encoding.time_L,
                    time_scale=cfg.encoding.time_scale,
                    base_time_freqs=base.time_L if base else 0,
                    base_time_scale=base.time_scale if base else 1.0,
                    deform_width=m.deform_width, deform_depth=m.deform_depth)


def is_dynamic(config, name: str) -> bool:
  """Whether stage `name`'s field takes time as an input."""
  return config[name].model.get("kind", "nerf") == "deform"


def epi_ray_field_from_config(joint_cfg):
  """EPIRayField of a stage's `joint` config."""
  m = joint_cfg.model
  return EPIRayField(std=joint_cfg.std, num_features=joint_cfg.num_features,
                     seed=joint_cfg.seed, width=m.width, depth=m.depth, skips=tuple(m.skips),
                     uv_std=joint_cfg.get("uv_std", 0.0),
                     color=joint_cfg.get("color_weight", 0.0) > 0)


def ray_field_from_config(cfg, near, far):
  """RayField from the ray stage config."""
  m = cfg.model
  return RayField(freqs=cfg.encoding.L, scale=cfg.encoding.scale, width=m.width,
                  depth=m.depth, skips=tuple(m.skips), near=near, far=far)
