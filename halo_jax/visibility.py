"""Which training cameras see a point: the frustum test, written for one point
and one camera and vmapped over both.

A point no training camera looks at is never on a training ray, so nothing in
the photometric loss constrains the density there (L_unseen,
stages/unseen.py, keeps it empty).
"""
import jax
import jax.numpy as jnp


def in_frustum(point, w2c, focal, width, height):
  """Whether `point` [3] projects inside a pinhole camera's image, in front of it.

  w2c: [3, 4] world-to-camera (OpenGL axes: the camera looks down -z, +y up);
  focal in pixels; width, height in pixels. Returns a bool scalar.
  """
  p = w2c[:, :3] @ point + w2c[:, 3]
  depth = -p[2]
  u = focal * p[0] / jnp.maximum(depth, 1e-9)
  v = focal * p[1] / jnp.maximum(depth, 1e-9)
  return (depth > 0) & (jnp.abs(u) <= 0.5 * width) & (jnp.abs(v) <= 0.5 * height)


def world_to_camera(c2w):
  """[V, 3, 4] world-to-camera matrices of camera-to-worlds c2w [V, 4, 4] (or [V, 3, 4])."""
  r, t = c2w[:, :3, :3], c2w[:, :3, 3]
  r_t = jnp.swapaxes(r, -1, -2)
  return jnp.concatenate([r_t, -(r_t @ t[..., None])], -1)


def seen_count(points, w2c, focal, width, height):
  """Number of cameras whose frustum holds each point.

  points [..., 3]; w2c [V, 3, 4] (world_to_camera). Returns int32 [...].
  """
  per_camera = jax.vmap(in_frustum, in_axes=(None, 0, None, None, None))
  per_point = jax.vmap(lambda x: per_camera(x, w2c, focal, width, height).sum())
  flat = points.reshape(-1, 3)
  return per_point(flat).astype(jnp.int32).reshape(points.shape[:-1])
