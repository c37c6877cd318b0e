"""Stiff and extreme cases for every numerical building block, each checked
against a closed form or a float64 numpy reference.

Each `case_*` function returns a list of `Check`s: the largest error of one
quantity against its reference, the tolerance it must meet, and whether every
value and gradient computed on the way was finite. `tests/test_stability.py`
asserts them; `experiments/stability.py` prints them as a table.
"""
import dataclasses
from typing import List

import jax
import jax.numpy as jnp
import numpy as np

from halo_jax import camera, encoding, losses, ray_fields, render, samplers
from halo_jax.frequency import spectrum as frequency

EPS32 = 2.0 ** -24


@dataclasses.dataclass
class Check:
  case: str
  quantity: str
  error: float
  tol: float
  reference: str
  finite: bool = True
  note: str = ""

  @property
  def ok(self) -> bool:
    return bool(self.finite and np.isfinite(self.error) and self.error <= self.tol)


def _finite(*trees) -> bool:
  return all(bool(np.all(np.isfinite(np.asarray(x))))
             for t in trees for x in jax.tree_util.tree_leaves(t))


def _max_abs(a, b) -> float:
  a, b = np.asarray(a, np.float64), np.asarray(b, np.float64)
  return float(np.max(np.abs(a - b))) if a.size else 0.0


def _max_rel(a, b, floor=1.0) -> float:
  a, b = np.asarray(a, np.float64), np.asarray(b, np.float64)
  return float(np.max(np.abs(a - b) / np.maximum(np.abs(b), floor)))


# ---------------------------------------------------------------- rendering

def render_reference(sigma, rgb, t_edges, white=True):
  """float64 numpy volume rendering (same definition, no fp32 shortcuts)."""
  sigma, rgb, t = (np.asarray(x, np.float64) for x in (sigma, rgb, t_edges))
  delta = np.diff(t, axis=-1)
  delta = np.where(np.isposinf(delta), render.INFINITE_DELTA, delta)
  od = np.where(sigma > 0, sigma * delta, 0.0)
  cum = np.cumsum(od, -1)
  trans = np.exp(-np.concatenate([np.zeros_like(cum[..., :1]), cum[..., :-1]], -1))
  w = trans * -np.expm1(-od)
  acc = w.sum(-1)
  color = (w[..., None] * rgb).sum(-2) + (1.0 - acc[..., None]) * white
  t_mid = t[..., :-1] + 0.5 * delta
  return {"weights": w, "acc": acc, "rgb": color, "depth": (w * t_mid).sum(-1)}


def _render_with_grads(sigma, rgb, t_edges):
  """fp32 render and the gradients of a loss touching every output."""
  def loss(s, c):
    out = render.volume_render(s, c, t_edges)
    depth = render.normalized_depth(out["depth"], out["acc"])
    return (losses.reconstruction(out["rgb"], 0.5) + jnp.mean(out["acc"])
            + jnp.mean(depth / jnp.maximum(t_edges[..., :1], 1.0)))
  out = render.volume_render(sigma, rgb, t_edges)
  grads = jax.grad(loss, argnums=(0, 1))(sigma, rgb)
  return out, grads


def _render_checks(case, sigma, rgb, t_edges, tol_w=1e-6, tol_depth=1e-5):
  sigma, rgb, t_edges = (jnp.asarray(x, jnp.float32) for x in (sigma, rgb, t_edges))
  out, grads = _render_with_grads(sigma, rgb, t_edges)
  ref = render_reference(sigma, rgb, t_edges)
  fin = _finite(out, grads)
  ref_name = "float64 numpy"
  return [
      Check(case, "weights", _max_abs(out["weights"], ref["weights"]), tol_w, ref_name, fin),
      Check(case, "opacity", _max_abs(out["acc"], ref["acc"]), tol_w, ref_name, fin),
      Check(case, "rgb", _max_abs(out["rgb"], ref["rgb"]), 2 * tol_w, ref_name, fin),
      Check(case, "depth (rel.)", _max_rel(out["depth"], ref["depth"]), tol_depth, ref_name, fin),
  ]


def case_render_constant_slabs() -> List[Check]:
  """Constant density on equal intervals: w_k = e^{-k s d} (1 - e^{-s d})."""
  n = 64
  # Binary-exact lengths (~1e-10, ~1e-2, 1, ~1e10) and fp32-exact densities so
  # the edges and inputs are the same numbers in fp32 and in the closed form.
  sig = np.float32([0.0, 1e-6, 1.0, 1e3, 1e10]).astype(np.float64)
  dlt = np.array([0.0, 2.0 ** -33, 2.0 ** -7, 1.0, 2.0 ** 33])
  s, d = [x.ravel() for x in np.meshgrid(sig, dlt, indexing="ij")]
  t_edges = d[:, None] * np.arange(n + 1)
  sigma = np.repeat(s[:, None], n, 1)
  rgb = np.broadcast_to([0.2, 0.5, 0.9], (len(s), n, 3))
  out, grads = _render_with_grads(*(jnp.asarray(x, jnp.float32) for x in (sigma, rgb, t_edges)))
  k = np.arange(n)
  sd = s[:, None] * d[:, None]
  w = np.exp(-k * sd) * -np.expm1(-sd)       # closed form, float64
  acc = -np.expm1(-n * sd[:, 0])
  fin = _finite(out, grads)
  return [Check("constant slabs, sigma in [0,1e10], delta in [0,1e10]", "weights",
                _max_abs(out["weights"], w), 1e-6, "closed form", fin),
          Check("constant slabs, sigma in [0,1e10], delta in [0,1e10]", "opacity",
                _max_abs(out["acc"], acc), 1e-6, "closed form", fin)]


def case_render_random_stiff() -> List[Check]:
  """Densities 1e-8..1e10 (and 0), lengths 1e-10..1e10 (and 0), at random."""
  rng = np.random.default_rng(0)
  r, n = 512, 32
  sigma = 10.0 ** rng.uniform(-8, 10, (r, n))
  sigma[rng.uniform(size=(r, n)) < 0.2] = 0.0
  delta = 10.0 ** rng.uniform(-10, 10, (r, n)) * (rng.uniform(size=(r, n)) > 0.1)
  t_edges = np.concatenate([np.full((r, 1), 2.0), 2.0 + np.cumsum(delta, -1)], -1)
  rgb = rng.uniform(size=(r, n, 3))
  # Depth is compared in float32's own terms: edges up to ~1e11 round at 1e-7.
  return _render_checks("random stiff rays", sigma, rgb, t_edges.astype(np.float32),
                        tol_w=1e-5, tol_depth=1e-5)


def case_render_infinite_last_interval() -> List[Check]:
  """A last edge of inf is an interval of INFINITE_DELTA (NeRF's 1e10)."""
  rng = np.random.default_rng(1)
  t_edges = np.concatenate([np.linspace(2.0, 6.0, 33), [np.inf]])
  sigma = np.tile(rng.uniform(0, 0.05, 33), (4, 1))
  sigma[:, -1] = [0.0, 1e-12, 0.5, 1e10]
  rgb = rng.uniform(size=(4, 33, 3))
  return _render_checks("last interval infinite", sigma, rgb, np.tile(t_edges, (4, 1)),
                        tol_depth=1e-5)


def case_render_empty_and_opaque() -> List[Check]:
  """All-empty rays: acc 0, white, depth 0. All-opaque: first interval takes all."""
  t_edges = jnp.linspace(2.0, 6.0, 65)
  rgb = jnp.full((64, 3), 0.3)
  empty, g_empty = _render_with_grads(jnp.zeros(64), rgb, t_edges)
  full, g_full = _render_with_grads(jnp.full((64,), 1e10), rgb, t_edges)
  t0 = float((t_edges[0] + t_edges[1]) / 2)
  err_empty = max(_max_abs(empty["acc"], 0.0), _max_abs(empty["rgb"], 1.0),
                  _max_abs(empty["depth"], 0.0))
  w_ref = np.zeros(64)
  w_ref[0] = 1.0
  err_full = max(_max_abs(full["weights"], w_ref), _max_abs(full["rgb"], 0.3),
                 _max_rel(full["depth"], t0), _max_rel(full["depth_max"], t0))
  return [Check("all-empty ray", "acc, rgb, depth", err_empty, 1e-7, "closed form",
                _finite(empty, g_empty)),
          Check("all-opaque ray (sigma 1e10)", "weights, rgb, depth", err_full, 1e-6,
                "closed form", _finite(full, g_full))]


# ---------------------------------------------------------------- encoding

def case_encoding_large_arguments() -> List[Check]:
  """sin/cos(2^k x / s) for x up to +-1e3 and L = 16 against float64.

  Tolerance: the compensated form's bound 2^-24 (4 + |angle| 2^-11), doubled.
  The naive form's error is reported in the note.
  """
  rng = np.random.default_rng(0)
  checks = []
  L = 16
  for mag in (4.0, 1e2, 1e3):
    for s in (1.0, 32.0, 7.0):
      x = rng.uniform(-mag, mag, (4096, 3)).astype(np.float32)
      xj = jnp.asarray(x)
      got = encoding.positional_encoding(xj, L, s, include_input=False)
      naive = encoding.naive_positional_encoding(xj, L, s)
      angles = (x.astype(np.float64) / s)[..., None, :] * (2.0 ** np.arange(L))[:, None]
      angles = angles.reshape(len(x), -1)
      want = np.concatenate([np.sin(angles), np.cos(angles)], -1)
      grad = jax.grad(lambda v: encoding.positional_encoding(v, L, s).sum())(xj)
      max_angle = float(np.abs(angles).max())
      checks.append(Check(
          f"P.E. x in +-{mag:g}, s={s:g}, L={L} (angles up to {max_angle:.1e})", "sin, cos",
          _max_abs(got, want), 2 * EPS32 * (4 + max_angle * 2.0 ** -11), "float64 numpy",
          _finite(got, grad), note=f"naive {_max_abs(naive, want):.1e}"))
  return checks


# ---------------------------------------------------------------- samplers

def case_depth_guided_sampler() -> List[Check]:
  """Predicted depth below near, above far, at the bounds, NaN and +-inf."""
  near, far, r, n = 2.0, 6.0, 0.3, 16
  depth = np.array([-5.0, 0.0, 2.0, 4.0, 6.0, 9.0, 1e30, np.nan, np.inf, -np.inf], np.float32)
  checks = []
  for near_only in (False, True):
    edges = samplers.depth_guided(jax.random.PRNGKey(0), jnp.asarray(depth), near, far, n, r,
                                  near_only=near_only)
    edges = np.asarray(edges, np.float64)
    half = r * (far - near)
    d = np.clip(np.nan_to_num(depth.astype(np.float64), nan=near, posinf=far, neginf=near),
                near, far)
    bad = ~np.isfinite(depth)
    lo_ref = np.where(bad, near, np.maximum(near, d - half))
    hi_ref = np.full_like(lo_ref, far) if near_only else np.where(bad, far, np.minimum(far, d + half))
    err = max(_max_abs(edges[:, 0], lo_ref), _max_abs(edges[:, -1], hi_ref))
    inside = np.all((edges >= lo_ref[:, None] - 1e-6) & (edges <= hi_ref[:, None] + 1e-6))
    sorted_ = np.all(np.diff(edges, axis=-1) >= 0)
    checks.append(Check(f"depth-guided window ({'near only' if near_only else 'both sides'})",
                        "window ends", err if inside and sorted_ else np.inf, 1e-6,
                        "closed form", _finite(edges)))
  return checks


# ---------------------------------------------------------------- criterion

def criterion_reference(images_a, images_b, mask_fraction=0.01):
  """float64 numpy version of frequency.spectrum_difference."""
  def grey(x):
    return np.clip(np.asarray(x, np.float64), 0, 1).mean(-1) * 255.0
  fa = np.fft.fft2(grey(images_a), norm="ortho")
  fb = np.fft.fft2(grey(images_b), norm="ortho")
  out = []
  for a, b in zip(fa, fb):
    mag = (0.5 * (np.abs(a) + np.abs(b))).ravel()
    keep = np.ones(mag.size, bool)
    keep[0] = False
    num_drop = int(round(mask_fraction * mag.size))
    if num_drop:
      ranked = np.argsort(-mag[1:], kind="stable") + 1   # without DC
      keep[ranked[:num_drop]] = False
    out.append(np.abs(a - b).ravel()[keep].mean())
  return float(np.mean(out))


def case_frequency_criterion() -> List[Check]:
  """Constant, black and saturated images give 0 (only DC differs, and DC is
  masked); random pairs match the float64 reference."""
  shape = (2, 32, 48, 3)
  black, white = np.zeros(shape, np.float32), np.ones(shape, np.float32)
  grey = np.full(shape, 0.3, np.float32)
  saturated = np.full(shape, 1.7, np.float32)   # clipped to 255
  zero_cases = [("black vs black", black, black), ("black vs white", black, white),
                ("constant vs constant", grey, white), ("saturated vs white", saturated, white)]
  checks = []
  for name, a, b in zero_cases:
    v = frequency.spectrum_difference(jnp.asarray(a), jnp.asarray(b))
    checks.append(Check(f"criterion: {name}", "sigma", abs(float(v)), 1e-4, "closed form 0",
                        _finite(v)))
  rng = np.random.default_rng(0)
  a = rng.uniform(-0.2, 1.2, shape).astype(np.float32)   # partly saturated
  b = np.clip(a + rng.normal(0, 0.05, shape), -1, 2).astype(np.float32)
  v = float(frequency.spectrum_difference(jnp.asarray(a), jnp.asarray(b)))
  ref = criterion_reference(a, b)
  checks.append(Check("criterion: noisy, partly saturated pair", "sigma (rel.)",
                      abs(v - ref) / ref, 1e-4, "float64 numpy", bool(np.isfinite(v))))
  return checks


# ---------------------------------------------------------------- ray field

def case_ray_field_missing_rays() -> List[Check]:
  """Rays that hit, graze and miss the sphere: entry points against the closed
  form; ray-field outputs inside [near, far]; L_ray gradients finite."""
  radius, near, far = 4.0, 2.0, 6.0
  o = np.array([[0, 0, 8.0], [4.0, 0, 8.0], [4.5, 0, 8.0], [10.0, 3, 8.0], [0, 0, 1.0]],
               np.float32)
  d = np.tile(np.array([[0, 0, -1.0]], np.float32), (len(o), 1))
  t, p, hit = camera.sphere_entry(jnp.asarray(o), jnp.asarray(d), radius)
  o64, d64 = o.astype(np.float64), d.astype(np.float64)
  b = (o64 * d64).sum(-1)
  disc = b ** 2 - ((o64 ** 2).sum(-1) - radius ** 2)
  t_ref = -b - np.sqrt(np.maximum(disc, 0.0))     # misses: closest point to the centre
  err_entry = max(_max_abs(t, t_ref), _max_abs(p, o64 + t_ref[:, None] * d64))
  g_entry = jax.grad(lambda oo: camera.sphere_entry(oo, jnp.asarray(d), radius)[1].sum())(
      jnp.asarray(o))
  hit_ok = np.array_equal(np.asarray(hit), disc >= 0)

  model = ray_fields.RayField(freqs=10, scale=32.0, width=32, depth=2, skips=(), near=near, far=far)
  params = model.init(jax.random.PRNGKey(0), p, jnp.asarray(d))["params"]
  # Push the depth head to saturation both ways: outputs must stay in range.
  big = jax.tree_util.tree_map(lambda x: x * 1e3, params)

  def loss(prm):
    depth, acc = model.apply({"params": prm}, p, jnp.asarray(d))
    return losses.ray_field(depth, acc, jnp.full_like(depth, far), jnp.zeros_like(acc), far)

  checks = [Check("sphere entry: hit, tangent, miss, inside", "t, point",
                  err_entry if hit_ok else np.inf, 1e-5, "closed form",
                  _finite(t, p, g_entry))]
  for name, prm in (("ray field, typical weights", params), ("ray field, weights x1e3", big)):
    depth, acc = model.apply({"params": prm}, p, jnp.asarray(d))
    lo = near + (far - near) * -0.001
    hi = near + (far - near) * 1.001
    outside = float(np.maximum(np.maximum(lo - np.asarray(depth), np.asarray(depth) - hi), 0).max())
    outside = max(outside, float(np.maximum(-np.asarray(acc), np.asarray(acc) - 1).max()), 0.0)
    checks.append(Check(f"{name}, rays missing the sphere", "distance outside range",
                        outside, 0.0, "bounds [near,far], [0,1]",
                        _finite(depth, acc, jax.grad(loss)(prm))))
  return checks


# ---------------------------------------------------------------- losses

def case_loss_values_and_gradients() -> List[Check]:
  """Each loss at its extremes against its closed form, gradients finite."""
  checks = []
  rgb = jnp.array([[0.0, 0.0, 0.0], [1.0, 1.0, 1.0]])
  target = jnp.array([[1.0, 1.0, 1.0], [1.0, 1.0, 1.0]])
  v, g = jax.value_and_grad(losses.reconstruction)(rgb, target)
  checks.append(Check("L_rec, all-wrong and all-right pixels", "value", abs(float(v) - 0.5),
                      1e-7, "closed form 0.5", _finite(v, g)))
  depth = jnp.array([2.0, 6.0, 6.0])
  acc = jnp.array([0.0, 1.0, 0.5])
  v, g = jax.value_and_grad(losses.ray_field, argnums=(0, 1))(
      depth, acc, jnp.array([6.0, 6.0, 2.0]), jnp.array([1.0, 1.0, 0.5]), 6.0)
  want = ((4 / 6) ** 2 + 0 + (4 / 6) ** 2) / 3 + (1 + 0 + 0) / 3
  checks.append(Check("L_ray, depth at near/far, acc 0/1", "value", abs(float(v) - want), 1e-6,
                      "closed form", _finite(v, g)))
  for name, lo_acc, want in (("no ray empty", jnp.ones(4), 0.0),
                             ("all rays empty", jnp.zeros(4), 0.625)):
    v, g = jax.value_and_grad(losses.empty_space)(jnp.array([1.0, 0.5, 0.0, 1.0]), lo_acc)
    checks.append(Check(f"L_empty, {name}", "value", abs(float(v) - want), 1e-7,
                        "closed form", _finite(v, g)))
  # End to end: gradients of L_rec through stiff rendering back to densities.
  sigma = jnp.array([0.0, 1e10, 1e-8, 1e10])
  t_edges = jnp.array([2.0, 2.0, 3.0, 3.0 + 1e-10, jnp.inf])
  g = jax.grad(lambda s: losses.reconstruction(
      render.volume_render(s, jnp.full((4, 3), 0.2), t_edges)["rgb"], 0.7))(sigma)
  checks.append(Check("L_rec through stiff rendering", "gradient finite", 0.0, 0.0,
                      "-", _finite(g)))
  return checks


CASES = (case_render_constant_slabs, case_render_random_stiff,
         case_render_infinite_last_interval, case_render_empty_and_opaque,
         case_encoding_large_arguments, case_depth_guided_sampler, case_frequency_criterion,
         case_ray_field_missing_rays, case_loss_values_and_gradients)


def run_all() -> List[Check]:
  return [c for case in CASES for c in case()]
