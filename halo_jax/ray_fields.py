"""Ray fields (light-field networks): one MLP query per ray answers where the
ray's surface is. `RayField` for 3D rays (an entry point on a sphere, or an
NDC ray, and a direction); `EPIRayField` for two-plane rays."""
from typing import Sequence

import flax.linen as nn
import jax
import jax.numpy as jnp
import numpy as np

from halo_jax import encoding
from halo_jax.geometry import Geometry
from halo_jax.models import MLP, _rows


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
  sin_cos: str = "polynomial"   # the encoding's sin and cos (trig.KINDS)

  @nn.compact
  def __call__(self, entry_points, directions):
    """Args: entry_points [..., 3], directions [..., 3]. Returns depth [...], acc [...]."""
    shape = entry_points.shape[:-1]
    pe = lambda p: encoding.positional_encoding(p, self.freqs, self.scale, sin_cos=self.sin_cos)
    x = jnp.concatenate([encoding.over_points(pe, _rows(entry_points)),
                         encoding.over_points(pe, _rows(directions))], -1)
    h = MLP(self.width, self.depth, tuple(self.skips), name="trunk")(x)
    out = nn.Dense(2, name="heads")(h).reshape(*shape, 2)
    unit = nn.sigmoid(out[..., 0]) * 1.002 - 0.001
    depth = self.near + (self.far - self.near) * unit
    acc = nn.sigmoid(out[..., 1])
    return depth, acc


def ray_field_matrix(seed: int, num_features: int, std: float, uv_std: float = 0.0):
  """EPIRayField's frequency matrix B [4 (u, v, s, t), F]: N(0, std^2), the
  (u, v) rows N(0, uv_std^2) where uv_std is not 0 (the same draw, rescaled)."""
  matrix = encoding.fourier_matrix(seed + encoding.FourierStream.RAY_FIELD, 4, num_features, std)
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
  sin_cos: str = "polynomial"   # the encoding's sin and cos (trig.KINDS)

  @nn.compact
  def __call__(self, rays):
    """Args: rays [..., 4] (u, v, s, t). Returns tau [...], or with `color`
    (tau [...], rgb [..., 3])."""
    rows = _rows(rays)
    matrix = ray_field_matrix(self.seed, self.num_features, self.std, self.uv_std)
    x = encoding.gaussian_fourier_features(rows, matrix, sin_cos=self.sin_cos)
    h = MLP(self.width, self.depth, tuple(self.skips), name="trunk")(x)
    tau = nn.sigmoid(nn.Dense(1, name="head")(h)[..., 0]) * 1.002 - 0.001
    tau = tau.reshape(rays.shape[:-1])
    if not self.color:
      return tau
    c = nn.relu(nn.Dense(self.width, name="color_hidden")(
        jnp.concatenate([h, rows[:, :2]], -1)))
    rgb = nn.sigmoid(nn.Dense(3, name="color")(c)) * 1.002 - 0.001
    return tau, rgb.reshape(*rays.shape[:-1], 3)


class NeLFRayField(nn.Module):
  """The authors' two-plane ray field (their `NeLFEPIField`): (u, v, s, t) ->
  tau_ray in [0, 1] and the ray's colour.

  (u, v) and (s, t) get per-coordinate Fourier features (encoding.
  fourier_encode of kind `uv_kind`, `st_kind`: 'axis' of std `uv_std`,
  `std`, or 'octaves' of that scale), `num_features` per coordinate; a
  `depth` x `width` ReLU trunk with the features concatenated back in at
  `skips`; tau from one hidden layer; the colour from one hidden layer over
  the trunk and, with `color_uv`, all of (u, v)'s features. Always has the
  colour head.
  """
  std: float = 5.09
  uv_std: float = 0.17
  num_features: int = 10
  uv_kind: str = "axis"
  st_kind: str = "axis"
  color_uv: bool = True
  seed: int = 0
  width: int = 256
  depth: int = 8
  skips: Sequence[int] = (4,)
  sin_cos: str = "polynomial"
  color: bool = True   # for the callers that ask; the head is always there

  @nn.compact
  def __call__(self, rays):
    """Args: rays [..., 4] (u, v, s, t). Returns tau [...], rgb [..., 3]."""
    rows = _rows(rays)
    stream = encoding.FourierStream
    uv = encoding.fourier_encode(rows[:, :2], self.uv_kind, self.seed + stream.NELF_UV,
                                 self.num_features, self.uv_std, sin_cos=self.sin_cos)
    st = encoding.fourier_encode(rows[:, 2:], self.st_kind, self.seed + stream.NELF_ST,
                                 self.num_features, self.std, sin_cos=self.sin_cos)
    h = MLP(self.width, self.depth, tuple(self.skips), name="trunk")(jnp.concatenate([uv, st], -1))
    tau_h = nn.relu(nn.Dense(self.width, name="tau_hidden")(h))
    tau = nn.sigmoid(nn.Dense(1, name="head")(tau_h)[..., 0]) * 1.002 - 0.001
    c = jnp.concatenate([h, uv], -1) if self.color_uv else h
    c = nn.relu(nn.Dense(self.width, name="color_hidden")(c))
    rgb = nn.sigmoid(nn.Dense(3, name="color")(c)) * 1.002 - 0.001
    return tau.reshape(rays.shape[:-1]), rgb.reshape(*rays.shape[:-1], 3)


def epi_ray_field_from_config(joint_cfg, sin_cos: str = "polynomial"):
  """The two-plane ray field of a stage's `joint` config (joint.field:
  'oblique', EPIRayField; 'nelf', the authors' NeLFRayField); sin_cos: the
  run config's."""
  m, kind = joint_cfg.model, joint_cfg.get("field", "oblique")
  if kind == "nelf":
    return NeLFRayField(std=joint_cfg.std, uv_std=joint_cfg.uv_std,
                        num_features=joint_cfg.num_features,
                        uv_kind=joint_cfg.get("uv_kind", "axis"),
                        st_kind=joint_cfg.get("st_kind", "axis"),
                        color_uv=joint_cfg.get("color_uv", True), seed=joint_cfg.seed,
                        width=m.width, depth=m.depth, skips=tuple(m.skips), sin_cos=sin_cos)
  if kind != "oblique":
    raise ValueError(f"joint.field={kind!r}: use 'oblique' or 'nelf'")
  return EPIRayField(std=joint_cfg.std, num_features=joint_cfg.num_features,
                     seed=joint_cfg.seed, width=m.width, depth=m.depth, skips=tuple(m.skips),
                     uv_std=joint_cfg.uv_std, color=joint_cfg.color_weight > 0,
                     sin_cos=sin_cos)


def guide_radius(ray_cfg, dataset) -> float:
  """The sphere on which a ray field enters rays, and from which random rays
  are cast: `ray.radius`, else the training cameras' mean distance from the
  origin (dataset.radius); 0 where rays are not spatial-spherical."""
  if dataset.geometry != Geometry.SPHERE:
    return 0.0
  return float(ray_cfg.radius or dataset.radius)


def ray_field_from_config(cfg, near, far, sin_cos: str = "polynomial"):
  """RayField from a ray-field config (encoding, model); sin_cos: the run config's."""
  m = cfg.model
  return RayField(freqs=cfg.encoding.L, scale=cfg.encoding.scale, width=m.width,
                  depth=m.depth, skips=tuple(m.skips), near=near, far=far, sin_cos=sin_cos)


def init_ray_field(model, seed: int):
  """RayField parameters from PRNGKey(seed)."""
  x = jnp.zeros((1, 3))
  return model.init(jax.random.PRNGKey(seed), x, x)["params"]
