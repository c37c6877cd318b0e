"""Flax models: the NeRF MLPs and the ray fields (light-field networks), and
the registry that builds a stage's radiance field from its config."""
import dataclasses
import functools
from typing import Callable, Sequence

import flax.linen as nn
import jax
import jax.numpy as jnp

from halo_jax import geometry

from halo_jax import encoding, registry, rng


def _rows(x):
  """x [..., C] as rows [N, C]. The fields run their layers on rows: XLA's CPU
  matmul is about twice as fast on [N, C] x [C, D] as on a [R, S, C] input,
  whose weight gradient contracts two axes."""
  return x.reshape(-1, x.shape[-1])


DENSITY_ACTIVATIONS = {"softplus": nn.softplus, "relu": nn.relu}


def _density(h, noise_key, noise, bias, shape, activation="softplus"):
  """The density head of a radiance field (call inside a compact module):
  act(Dense(h) + noise + bias) for rows h [N, W] of points of `shape`
  (N = prod(shape)); returns [N]. Noise only when a key (one, or per ray:
  halo_jax.rng, drawn over `shape` so each ray draws its own) is given.
  act: 'softplus' (smooth, never stuck at 0) or 'relu' (the original NeRF)."""
  raw = nn.Dense(1, dtype=jnp.float32, name="density")(h)[..., 0]
  if noise_key is not None and noise > 0:
    raw = raw + noise * rng.normal(noise_key, shape).reshape(raw.shape)
  return DENSITY_ACTIVATIONS[activation](raw + bias)


def band_weights(band_fraction, num_bands: int, dims: int):
  """FreeNeRF's frequency mask over a P.E. of `num_bands` (L) bands of `dims`
  coordinates ordered (band, dim).

  With p = min(L * band_fraction + 1, L), band k has weight clip(p - k, 0, 1):
  at fraction 0 only the lowest band is visible, bands open one after
  another as the fraction grows, and all are open from fraction 1 - 1/L on.
  Returns [L * dims]; band_fraction may be traced.
  """
  k = jnp.arange(num_bands, dtype=jnp.float32)
  frac = jnp.asarray(band_fraction, jnp.float32)
  p = jnp.minimum(num_bands * frac + 1.0, float(num_bands))
  return jnp.repeat(jnp.clip(p - k, 0.0, 1.0), dims)


def masked_positional_encoding(x, freqs, scale, band_fraction, sin_cos="polynomial"):
  """positional_encoding(x) with FreeNeRF's mask on its sin and cos halves
  (no mask when band_fraction is None)."""
  pe = encoding.positional_encoding(x, freqs, scale, sin_cos=sin_cos)
  if band_fraction is None:
    return pe
  w = band_weights(band_fraction, freqs, x.shape[-1])
  # the input itself (the first D features) stays visible, as in FreeNeRF
  return pe * jnp.concatenate([jnp.ones(x.shape[-1]), w, w])


COMPUTE_DTYPES = {"float32": jnp.float32, "bfloat16": jnp.bfloat16}

# bfloat16 operands, float32 products and sums. XLA's CPU back end runs this
# form of [N, K] @ [K, M] on its bfloat16 kernels (avx512_bf16); a dot whose
# result is bfloat16 is turned back into a float32 dot plus conversions. The
# gradient's products are float32 (the back end upcasts them either way).
_F32_ACCUMULATE = functools.partial(jax.lax.dot_general, preferred_element_type=jnp.float32)


def dense(features: int, dtype: str, name: str) -> nn.Dense:
  """A Dense layer computing in `dtype` (COMPUTE_DTYPES) with float32
  parameters; a bfloat16 one accumulates and returns float32."""
  if dtype == "float32":
    return nn.Dense(features, dtype=jnp.float32, name=name)
  return nn.Dense(features, dtype=COMPUTE_DTYPES[dtype], dot_general=_F32_ACCUMULATE,
                  name=name)


class MLP(nn.Module):
  """ReLU MLP with the input concatenated back in after the `skips` layers.
  dtype: the layers' compute dtype (their parameters stay float32)."""
  width: int = 256
  depth: int = 8
  skips: Sequence[int] = (4,)
  dtype: str = "float32"

  @nn.compact
  def __call__(self, x):
    inputs = x
    for i in range(self.depth):
      if i in self.skips and i > 0:
        x = jnp.concatenate([x, inputs], -1)
      x = nn.relu(dense(self.width, self.dtype, f"dense_{i}")(x))
    return x


class NeRFMLP(nn.Module):
  """Radiance field: point (and view direction) -> density and colour.

  Attributes:
    pos_freqs, pos_scale: L and s of the point encoding (Lo or Hi P.E.).
    base_freqs, base_scale: when base_freqs > 0, a second (Lo) P.E. placed
      before the first, so a Hi-NeRF can start as an exact copy of a Lo-NeRF
      (see stages.transfer.transfer_from_lo).
    width, depth, skips: trunk size.
    use_viewdirs: condition colour on the view direction (Hi-NeRF); Lo-NeRF
      leaves it out so its colour is view-independent.
    dir_freqs: L of the direction encoding.
    density_bias: act(raw + bias); -1 starts a softplus field at about 0.31
      per unit (softplus(-1)), -4 at about 0.018.
    density_activation: 'softplus' or 'relu' (DENSITY_ACTIVATIONS).
    compute_dtype: 'float32' or 'bfloat16' (COMPUTE_DTYPES): the dtype of
      the trunk's and the view layers' matmuls; parameters, the encodings
      and the density and colour heads stay float32.
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
  density_activation: str = "softplus"
  compute_dtype: str = "float32"
  sin_cos: str = "polynomial"   # the encodings' sin and cos (trig.KINDS)

  @nn.compact
  def __call__(self, points, viewdirs=None, density_noise_key=None, density_noise=0.0,
               band_fraction=None):
    """points [..., 3], unit viewdirs [..., 3] or None -> sigma [...] >= 0, rgb
    [..., 3] in (0, 1). band_fraction: FreeNeRF's mask position in [0, 1]
    over the point and direction encodings (band_weights), or None."""
    shape = points.shape[:-1]
    points = _rows(points)
    x = encoding.over_points(lambda p: masked_positional_encoding(
        p, self.pos_freqs, self.pos_scale, band_fraction, self.sin_cos), points)
    if self.base_freqs > 0:
      x = jnp.concatenate([encoding.over_points(lambda p: encoding.positional_encoding(
          p, self.base_freqs, self.base_scale, sin_cos=self.sin_cos), points), x], -1)
    h = MLP(self.width, self.depth, tuple(self.skips), self.compute_dtype, name="trunk")(x)
    sigma = _density(h, density_noise_key, density_noise, self.density_bias, shape,
                     self.density_activation)
    if self.use_viewdirs:
      feat = dense(self.width, self.compute_dtype, "bottleneck")(h)
      viewdirs = _rows(jnp.broadcast_to(viewdirs, (*shape, viewdirs.shape[-1])))
      d = encoding.over_points(
          lambda v: masked_positional_encoding(v, self.dir_freqs, 1.0, band_fraction,
                                               self.sin_cos), viewdirs)
      h = nn.relu(dense(self.width // 2, self.compute_dtype, "view")(
          jnp.concatenate([feat, d], -1)))
    rgb = nn.sigmoid(nn.Dense(3, dtype=jnp.float32, name="rgb")(h))
    return sigma.reshape(shape), rgb.reshape(*shape, 3)


class DeformNeRF(NeRFMLP):
  """Dynamic radiance field (D-NeRF style): a deformation MLP maps a point at
  time t to a canonical point, which a static NeRFMLP colours.

  x' = x + D(gamma(x), gamma_t(t)), then sigma, rgb = NeRF(x'). D's output
  layer starts at zero, so the field starts static. With base_freqs > 0 the
  Lo encodings of x and t come first in D's input and in the canonical
  NeRF's (as in NeRFMLP), so a Hi model can start as a copy of a Lo model.

  Attributes (beside NeRFMLP's, which the canonical NeRF takes):
    time_freqs, time_scale: L and s of the time encoding (its own frequencies).
    base_time_freqs, base_time_scale: the Lo time encoding, with base_freqs.
    deform_width, deform_depth: size of the deformation MLP.
  """
  time_freqs: int = 6
  time_scale: float = 1.0
  base_time_freqs: int = 0
  base_time_scale: float = 1.0
  deform_width: int = 128
  deform_depth: int = 4

  @nn.compact
  def __call__(self, points, viewdirs=None, density_noise_key=None, density_noise=0.0,
               times=None, band_fraction=None):
    """points [..., 3], viewdirs [..., 3] or None, times [..., 1] in [0, 1] ->
    sigma [...] >= 0, rgb [..., 3] in (0, 1). band_fraction: FreeNeRF's mask
    over the encodings of x, t (the deformation's input) and of the canonical
    NeRF, or None."""
    if times is None:
      raise ValueError("DeformNeRF needs times [..., 1] (a dynamic scene)")
    shape = points.shape[:-1]
    x, times = _rows(points), _rows(jnp.broadcast_to(times, (*shape, 1)))
    def encode(row):  # one point's (x, y, z, t)
      point, time = row[:3], row[3:]
      feats = [masked_positional_encoding(point, self.pos_freqs, self.pos_scale, band_fraction,
                                          self.sin_cos),
               masked_positional_encoding(time, self.time_freqs, self.time_scale, band_fraction,
                                          self.sin_cos)]
      if self.base_freqs > 0:
        feats = [encoding.positional_encoding(point, self.base_freqs, self.base_scale,
                                              sin_cos=self.sin_cos),
                 encoding.positional_encoding(time, self.base_time_freqs,
                                              self.base_time_scale, sin_cos=self.sin_cos)] + feats
      return jnp.concatenate(feats, -1)
    h = MLP(self.deform_width, self.deform_depth, (), self.compute_dtype, name="deform")(
        encoding.over_points(encode, jnp.concatenate([x, times], -1)))
    offset = nn.Dense(3, kernel_init=nn.initializers.zeros, dtype=jnp.float32,
                      name="offset")(h).reshape(*shape, 3)
    canonical = NeRFMLP(**{f.name: getattr(self, f.name) for f in _NERF_FIELDS},
                        name="canonical")
    return canonical(points + offset, viewdirs, density_noise_key, density_noise, band_fraction)


# the canonical NeRF's attributes: NeRFMLP's own, without Flax's parent and name
_NERF_FIELDS = tuple(f for f in dataclasses.fields(NeRFMLP) if f.name not in ("parent", "name"))


class EPINeRF(nn.Module):
  """Radiance field of a two-plane light field in EPI coordinates (docs/scene_kinds.md).

  Points are (s', t', theta): the image-plane position aligned to the central
  view and the EPI angle; the view input is the camera-plane (u, v). Inputs
  are encoded with Fourier features: s', t' with std `st_std`,
  theta with `theta_std`, u, v with `uv_std` (counts `*_features`, fixed
  frequencies from `seed`). Each input's `*_kind` picks its encoder:
  'gaussian' Gaussian matrices (oblique projections, the input prepended);
  'axis' the authors' NormalEmbedder (sorted scalar frequencies applied to
  each coordinate, no input); 'octaves' their BaseEmbedder (2^k / std, std
  read as the scale). The colour reads the lowest `uv_features` of
  `uv_drawn` drawn.
  """
  st_std: float = 5.09
  st_features: int = 10
  theta_std: float = 8.0
  theta_features: int = 5
  uv_std: float = 1.0
  uv_features: int = 0
  uv_drawn: int = 0
  st_kind: str = "gaussian"
  theta_kind: str = "gaussian"
  uv_kind: str = "gaussian"
  seed: int = 0
  width: int = 256
  depth: int = 8
  skips: Sequence[int] = (4,)
  color_width: int = 0             # the colour's hidden layer (0: width // 2)
  density_bias: float = -1.0
  density_activation: str = "softplus"
  compute_dtype: str = "float32"   # as in NeRFMLP
  sin_cos: str = "polynomial"      # as in NeRFMLP

  def _encode(self, x, kind, stream, num, std, drawn=0):
    return encoding.fourier_encode(x, kind, self.seed + stream, num, std, drawn, self.sin_cos)

  @nn.compact
  def __call__(self, points, viewdirs, density_noise_key=None, density_noise=0.0):
    """points [..., 3] (s', t', theta), viewdirs [..., 2] (u, v) -> sigma
    [...] >= 0, rgb [..., 3] in (0, 1)."""
    shape = points.shape[:-1]
    points, viewdirs = _rows(points), _rows(jnp.broadcast_to(viewdirs, (*shape, 2)))
    stream = encoding.FourierStream
    x = jnp.concatenate([
        self._encode(points[..., :2], self.st_kind, stream.EPI_ST, self.st_features,
                     self.st_std),
        self._encode(points[..., 2:], self.theta_kind, stream.EPI_THETA, self.theta_features,
                     self.theta_std)], -1)
    h = MLP(self.width, self.depth, tuple(self.skips), self.compute_dtype, name="trunk")(x)
    sigma = _density(h, density_noise_key, density_noise, self.density_bias, shape,
                     self.density_activation)
    v = self._encode(viewdirs, self.uv_kind, stream.EPI_UV, self.uv_features, self.uv_std,
                     self.uv_drawn)
    feat = dense(self.width, self.compute_dtype, "bottleneck")(h)
    h = nn.relu(dense(self.color_width or self.width // 2, self.compute_dtype, "view")(
        jnp.concatenate([feat, v], -1)))
    rgb = nn.sigmoid(nn.Dense(3, dtype=jnp.float32, name="rgb")(h))
    return sigma.reshape(shape), rgb.reshape(*shape, 3)


def sin_cos_of(config) -> str:
  """How a run's models evaluate sin and cos (config.sin_cos; older saved
  configs have no field: the polynomials)."""
  return config.get("sin_cos", "polynomial")


def _nerf_kwargs(config, name):
  cfg, m = config[name], config[name].model
  base = config.lo.encoding if cfg.encoding.with_lo else None
  return base, dict(pos_freqs=cfg.encoding.L, pos_scale=cfg.encoding.scale,
                    base_freqs=base.L if base else 0, base_scale=base.scale if base else 1.0,
                    width=m.width, depth=m.depth, skips=tuple(m.skips),
                    use_viewdirs=m.use_viewdirs, dir_freqs=m.dir_freqs,
                    density_bias=m.density_bias,
                    density_activation=m.density_activation,
                    compute_dtype=m.compute_dtype, sin_cos=sin_cos_of(config))


def _static_nerf(config, name):
  return NeRFMLP(**_nerf_kwargs(config, name)[1])


def _deform_nerf(config, name):
  base, common = _nerf_kwargs(config, name)
  cfg, m = config[name], config[name].model
  return DeformNeRF(**common, time_freqs=cfg.encoding.time_L,
                    time_scale=cfg.encoding.time_scale,
                    base_time_freqs=base.time_L if base else 0,
                    base_time_scale=base.time_scale if base else 1.0,
                    deform_width=m.deform_width, deform_depth=m.deform_depth)


def _epi_nerf(config, name):
  cfg, m = config[name], config[name].model
  f = cfg.fourier
  return EPINeRF(st_std=f.st_std, st_features=f.st_features, theta_std=f.theta_std,
                 theta_features=f.theta_features, uv_std=f.uv_std,
                 uv_features=f.uv_features, uv_drawn=f.get("uv_drawn", 0),
                 st_kind=f.get("st_kind", "gaussian"), theta_kind=f.get("theta_kind", "gaussian"),
                 uv_kind=f.get("uv_kind", "gaussian"), seed=f.seed, width=m.width, depth=m.depth,
                 skips=tuple(m.skips), color_width=m.get("color_width", 0),
                 density_bias=m.density_bias,
                 density_activation=m.get("density_activation", "softplus"),
                 compute_dtype=m.compute_dtype, sin_cos=sin_cos_of(config))


@dataclasses.dataclass(frozen=True)
class ModelSpec:
  """A radiance-field kind (config `<stage>.model.kind`).

  build: (config, stage name) -> Flax module.
  dummy_inputs: the (points, view) arrays `init` is called with.
  dynamic: the field takes a time input.
  geometries: the ray geometries it can be rendered in.
  """
  build: Callable
  dummy_inputs: Callable
  dynamic: bool = False
  geometries: frozenset = geometry.SPATIAL


MODELS = registry.Registry[ModelSpec]("model")
MODELS.register("nerf", ModelSpec(_static_nerf, lambda: (jnp.zeros((1, 3)), jnp.zeros((1, 3)))))
MODELS.register("deform", ModelSpec(_deform_nerf,
                                    lambda: (jnp.zeros((1, 3)), jnp.zeros((1, 3))), dynamic=True))
MODELS.register("epi", ModelSpec(_epi_nerf, lambda: (jnp.zeros((1, 3)), jnp.zeros((1, 2))),
                                 geometries=frozenset({geometry.Geometry.TWO_PLANE})))


def nerf_from_config(config, name: str):
  """The radiance field of stage `name` (config[name].model.kind in MODELS).

  With config[name].encoding.with_lo, Lo-NeRF's P.E. (config.lo.encoding) is
  prepended to the stage's own.
  """
  kind = config[name].model.kind
  return MODELS.get(kind, f"{name}.model.kind").build(config, name)


def init_nerf(model, kind: str, seed: int):
  """Parameters of a radiance field of MODELS kind `kind` from PRNGKey(seed)."""
  points, views = MODELS.get(kind).dummy_inputs()
  extra = {"times": jnp.zeros((1, 1))} if MODELS.get(kind).dynamic else {}
  return model.init(jax.random.PRNGKey(seed), points, views, **extra)["params"]


def is_dynamic(config, name: str) -> bool:
  """Whether stage `name`'s field takes time as an input."""
  return MODELS.get(config[name].model.kind, f"{name}.model.kind").dynamic
