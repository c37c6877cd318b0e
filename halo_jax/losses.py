"""HALO's losses as pure functions.

Each loss is written for one ray (or one point) and made a batch loss in one
place, `over_rays`: jax.vmap over the leading axis, then the mean over the
rays (or, with weights, over the rays that count). The batch forms below take
any leading axes and flatten them to rays.
"""
from typing import Callable

import jax
import jax.numpy as jnp


def over_rays(per_ray: Callable, *rows, weights=None):
  """The batch form of a per-ray loss per_ray (one ray's arguments ->
  scalar) over rows, each [R, ...]: mean_r per_ray(row r); with weights [R]
  (bool or float), sum_r w_r l_r / max(sum_r w_r, 1), the mean over the rays
  that count (0 when none does)."""
  values = jax.vmap(per_ray)(*rows)
  if weights is None:
    return jnp.mean(values)
  weights = weights.astype(values.dtype)
  return (values * weights).sum() / jnp.maximum(weights.sum(), 1.0)


def _rows(x, width: int = 0):
  """x as rays on one leading axis: [R] (width 0) or [R, width]."""
  return x.reshape(-1) if not width else x.reshape(-1, width)


# --- one ray ---------------------------------------------------------------

def squared_error(rgb, target):
  """One ray's colour error: rgb, target [3] -> mean squared difference."""
  return jnp.mean((rgb - target) ** 2)


def ray_field_error(depth, acc, depth_target, acc_target, far, acc_weight=1.0):
  """One ray's L_ray: ((d - d_lo) / far)^2 + acc_weight (acc - acc_lo)^2, scalars."""
  return ((depth - depth_target) / far) ** 2 + acc_weight * (acc - acc_target) ** 2


def near_density(sigma, num_near: int):
  """One ray's occlusion penalty: mean density of its first num_near samples,
  sigma [N] ordered from near to far."""
  return jnp.mean(sigma[:num_near])


def consistency_error(tau_ray, tau_target):
  """One ray's L_consist: (tau_ray - tau_target)^2, scalars."""
  return (tau_ray - tau_target) ** 2


# --- batches ---------------------------------------------------------------

def reconstruction(rgb, target):
  """L_rec: mean squared colour error. rgb [..., 3], target broadcastable
  to it -> scalar."""
  target = jnp.broadcast_to(target, rgb.shape)
  return over_rays(squared_error, _rows(rgb, 3), _rows(target, 3))


def ray_field(depth, acc, depth_target, acc_target, far, acc_weight=1.0):
  """L_ray = MSE(d / far, d_lo / far) + acc_weight MSE(acc, acc_lo). All [...]
  -> scalar (acc_weight 0: the depth term alone; an array [...] of them
  weighs each ray's opacity term on its own)."""
  if jnp.ndim(acc_weight) == 0:
    return over_rays(lambda d, a, dt, at: ray_field_error(d, a, dt, at, far, acc_weight),
                     *(_rows(x) for x in (depth, acc, depth_target, acc_target)))
  return over_rays(lambda d, a, dt, at, w: ray_field_error(d, a, dt, at, far, w),
                   *(_rows(x) for x in (depth, acc, depth_target, acc_target, acc_weight)))


def empty_space(acc, lo_acc, tau: float = 0.01):
  """L_empty: mean Hi-NeRF opacity acc [R] on random rays over those the
  Lo-NeRF sees as empty (lo_acc [R] < tau); 0 when none is."""
  return over_rays(lambda a: a, _rows(acc), weights=_rows(lo_acc) < tau)


def consistency(tau_ray, tau_target):
  """L_consist = mean |tau_ray - tau_target|^2 (light fields: the ray field's
  EPI depth against the radiance field's). [...] -> scalar."""
  return over_rays(consistency_error, _rows(tau_ray), _rows(tau_target))


def occlusion(sigma, num_near: int):
  """FreeNeRF's occlusion loss: mean density of the `num_near` samples nearest
  the camera, sigma [..., N] ordered from near to far -> scalar.

  Few views explain a pixel cheaply with density right in front of its
  camera ("floaters", walls); this term charges for it. FreeNeRF's optional
  prior that also masks more samples of white or black pixels is left out.
  """
  return over_rays(lambda s: near_density(s, num_near), _rows(sigma, sigma.shape[-1]))


def unseen_density(sigma, unseen):
  """L_unseen: mean density over the points that no training camera sees.

  sigma [...] >= 0, unseen [...] bool (or 0/1) -> scalar; 0 when no point is
  unseen. Density, not opacity, so that thick fog pulls as hard as thin.
  """
  return over_rays(lambda s: s, _rows(sigma), weights=_rows(unseen))
