"""Two-plane light fields: the EPI point parameterisation and the joint
sampler's schedule (docs/scene_kinds.md). Pure functions.

A ray is (u, v, s, t): u, v on the camera plane, s, t on the image plane. A
point on it is (u, v, s, t, theta), theta the slope of its line in the
epipolar-plane image; delta = cot(theta) is its normalised disparity: the
same point is seen at s - (u - u') delta from camera u'. Aligning every point
to one camera (u*, v*) gives the 3D point (s', t', theta).
"""
import jax.numpy as jnp

from halo_jax import render


def epi_points(uv, st, theta, uv_star=(0.0, 0.0)):
  """Aligns points on two-plane rays to the camera (u*, v*).

  s' = s + (u - u*) cot(theta), t' = t + (v - v*) cot(theta).

  Rays' camera-plane uv [..., 2] and image-plane st [..., 2], the points' EPI
  angles theta [...] in (0, pi), the camera uv_star they are aligned to ->
  points (s', t', theta) [..., 3].
  """
  cot = jnp.cos(theta) / jnp.sin(theta)
  aligned = st + (uv - jnp.asarray(uv_star, uv.dtype)) * cot[..., None]
  return jnp.concatenate([aligned, theta[..., None]], -1)


def theta_of_tau(tau, theta_n, theta_f):
  """tau in [0, 1] along the angle range -> theta."""
  return theta_n + (theta_f - theta_n) * tau


def depth_points(uv, st, tau, near, far, uv_star=(0.0, 0.0)):
  """Aligns points on two-plane rays to the camera (u*, v*), the planes in
  space (an LLFF scene's, datasets/llff_planes.py): the (u, v) plane through
  the cameras, the (s, t) plane at distance `far` from it, both in one frame.

  A point at distance d = near + tau (far - near) from the (u, v) plane lies
  on the line from u* that meets the (s, t) plane at
  s' = s + (u - u*) (far - d) / d. The rays' uv, st [..., 2] and the points'
  depth fractions tau [...] in [0, 1] (far: also the (s, t) plane's
  distance) -> points (s', t', tau) [..., 3].
  """
  d = near + (far - near) * tau
  slope = (far - d) / d
  aligned = st + (uv - jnp.asarray(uv_star, uv.dtype)) * slope[..., None]
  return jnp.concatenate([aligned, tau[..., None]], -1)


# How a two-plane dataset's [near, far] reads (Dataset.epi_slope): 'angle',
# EPI angles theta (the Stanford archive's grid); 'depth', distances from
# the (u, v) plane, the (s, t) plane at far (planes placed in a 3D scene).
SLOPES = ("angle", "depth")


def ray_points(uv, st, tau_edges, theta_n, theta_f, slope: str = "angle"):
  """One two-plane ray's (uv, st [2]) points at the midpoints of its
  intervals, sorted tau_edges [N + 1] in [0, 1] over theta_n..theta_f
  (angles, or depths: `slope`, SLOPES): points [N, 3] ((s', t', theta) or
  (s', t', tau)) and the field's view input, uv [N, 2]."""
  tau = render.interval_midpoints(tau_edges)
  if slope == "depth":
    points = depth_points(uv[None, :], st[None, :], tau, theta_n, theta_f)
  else:
    points = epi_points(uv[None, :], st[None, :], theta_of_tau(tau, theta_n, theta_f))
  return points, jnp.broadcast_to(uv, (*points.shape[:-1], 2))


def alpha_schedule(step, steps: int, final: float):
  """The joint sampler's window scale: 1 at step 0, linearly to `final` at
  `steps`, then constant."""
  frac = jnp.clip(jnp.asarray(step, jnp.float32) / max(steps, 1), 0.0, 1.0)
  return 1.0 - (1.0 - final) * frac
