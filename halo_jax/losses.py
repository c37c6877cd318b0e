"""HALO's losses as pure functions."""
import jax.numpy as jnp


def reconstruction(rgb, target):
  """L_rec: mean squared colour error. rgb, target [..., 3] -> scalar."""
  return jnp.mean((rgb - target) ** 2)


def ray_field(depth, acc, depth_target, acc_target, far):
  """L_ray = MSE(d / far, d_lo / far) + MSE(acc, acc_lo). All [...] -> scalar."""
  return jnp.mean(((depth - depth_target) / far) ** 2) + jnp.mean((acc - acc_target) ** 2)


def empty_space(acc, lo_acc, tau: float = 0.01):
  """L_empty: mean Hi-NeRF opacity over rays the Lo-NeRF sees as empty.

  Args:
    acc: [R] Hi-NeRF opacity on random rays.
    lo_acc: [R] Lo-NeRF opacity on the same rays.
    tau: a ray counts as empty when lo_acc < tau.

  Returns:
    scalar; 0 when no ray is empty.
  """
  empty = (lo_acc < tau).astype(acc.dtype)
  return (acc * empty).sum() / jnp.maximum(empty.sum(), 1.0)


def consistency(tau_ray, tau_target):
  """L_consist = mean |tau_ray - tau_target|^2 (light fields: the ray field's
  EPI depth against the radiance field's). [...] -> scalar."""
  return jnp.mean((tau_ray - tau_target) ** 2)


def occlusion(sigma, num_near: int):
  """FreeNeRF's occlusion loss: mean density of the `num_near` samples nearest
  the camera, sigma [..., N] ordered from near to far -> scalar.

  Few views explain a pixel cheaply with density right in front of its
  camera ("floaters", walls); this term charges for it. FreeNeRF's optional
  prior that also masks more samples of white or black pixels is left out.
  """
  return jnp.mean(sigma[..., :num_near])


def unseen_density(sigma, unseen):
  """L_unseen: mean density over the points that no training camera sees.

  sigma [...] >= 0, unseen [...] bool (or 0/1) -> scalar; 0 when no point is
  unseen. Density, not opacity, so that thick fog pulls as hard as thin.
  """
  unseen = unseen.astype(sigma.dtype)
  return (sigma * unseen).sum() / jnp.maximum(unseen.sum(), 1.0)
