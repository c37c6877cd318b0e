"""Cameras and rays: pixel rays, orbit and hemisphere cameras, sphere hits."""
import jax
import jax.numpy as jnp
import numpy as np


def pixel_rays(c2w, height: int, width: int, focal: float):
  """Rays through the pixel centres of a pinhole camera c2w ([3, 4] or [4, 4],
  OpenGL/Blender axes: looking down -z, +y up) with focal length `focal` in
  pixels: origins, unit directions [H, W, 3] (numpy float32)."""
  return pinhole_rays(c2w, height, width, (focal, focal, 0.5 * width, 0.5 * height))


def pinhole_rays(c2w, height: int, width: int, intrinsics):
  """pixel_rays for any pinhole camera: intrinsics (fx, fy, cx, cy) in
  pixels, the principal point (cx, cy) measured from the image's top-left
  corner. Returns origins, unit directions [H, W, 3] (numpy float32)."""
  fx, fy, cx, cy = (float(v) for v in intrinsics)
  c2w = np.asarray(c2w, np.float64)
  i, j = np.meshgrid(np.arange(width) + 0.5, np.arange(height) + 0.5, indexing="xy")
  dirs_cam = np.stack([(i - cx) / fx, -(j - cy) / fy, -np.ones_like(i)], -1)
  dirs = dirs_cam @ c2w[:3, :3].T
  dirs /= np.linalg.norm(dirs, axis=-1, keepdims=True)
  origins = np.broadcast_to(c2w[:3, 3], dirs.shape)
  return origins.astype(np.float32), dirs.astype(np.float32)


def opencv_to_opengl(c2w):
  """Camera-to-world [..., 3 or 4, 4] with OpenCV axes (x right, y down,
  looking down +z) as [..., 4, 4] with OpenGL's (y up, looking down -z), or
  back: flipping the y and z axes is its own inverse."""
  c2w = np.asarray(c2w, np.float64)
  out = np.broadcast_to(np.eye(4), c2w.shape[:-2] + (4, 4)).copy()
  out[..., :3, :4] = c2w[..., :3, :4]
  out[..., :3, 1:3] *= -1
  return out


def look_at(position, target=(0.0, 0.0, 0.0), up=(0.0, 0.0, 1.0)):
  """Camera-to-world [4, 4] for a camera at `position` looking at `target`."""
  position = np.asarray(position, np.float64)
  forward = np.asarray(target, np.float64) - position
  forward /= np.linalg.norm(forward)
  right = np.cross(forward, np.asarray(up, np.float64))
  if np.linalg.norm(right) < 1e-8:  # looking straight along `up`
    right = np.cross(forward, np.array([0.0, 1.0, 0.0]))
  right /= np.linalg.norm(right)
  cam_up = np.cross(right, forward)
  c2w = np.eye(4)
  c2w[:3, 0], c2w[:3, 1], c2w[:3, 2], c2w[:3, 3] = right, cam_up, -forward, position
  return c2w


def spherical_camera(radius, azimuth_deg, elevation_deg):
  """Camera on a sphere of `radius` around the origin, looking at it, z up."""
  az, el = np.deg2rad(azimuth_deg), np.deg2rad(elevation_deg)
  pos = radius * np.array([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el)])
  return look_at(pos)


def orbit_path(radius: float, num_frames: int, elevation_deg: float = 30.0):
  """The 360-degree orbit used for Blender videos: [F, 4, 4] camera-to-worlds."""
  return np.stack([spherical_camera(radius, az, elevation_deg)
                   for az in np.linspace(0.0, 360.0, num_frames, endpoint=False)])


def rays_between(key, origins, dirs, num_rays: int):
  """Random rays between given rays: each a random mix (1 - a) r_i + a r_j,
  of origins and of directions alike, of two rays drawn at random, a uniform
  in [0, 1]. In NDC a ray is its origin on the near plane and its step to the
  far plane, both affine in the camera's position and pixel, so a mix of two
  training rays is a ray that a camera between theirs could see: the random
  rays of forward-facing scenes, which have no hemisphere of cameras.
  origins, dirs [R, 3] (numpy or jax) -> num_rays of them, [B, 3] each (jax
  float32).
  """
  k_i, k_j, k_a = jax.random.split(key, 3)
  origins = jnp.asarray(origins, jnp.float32)
  dirs = jnp.asarray(dirs, jnp.float32)
  i = jax.random.randint(k_i, (num_rays,), 0, origins.shape[0])
  j = jax.random.randint(k_j, (num_rays,), 0, origins.shape[0])
  a = jax.random.uniform(k_a, (num_rays, 1))
  return (1.0 - a) * origins[i] + a * origins[j], (1.0 - a) * dirs[i] + a * dirs[j]


def random_hemisphere_rays(key, num_rays: int, radius: float, focal_over_width: float):
  """Rays from random cameras on the upper hemisphere, looking at the origin.

  Each ray gets its own camera (uniform on the hemisphere's area, elevation >= 0)
  and a uniformly random pixel of a unit-width image plane with the given
  focal / width ratio, as the ray field and L_empty use: origins, unit
  directions [num_rays, 3] (jax float32).
  """
  k_cam, k_az, k_px = jax.random.split(key, 3)
  z = jax.random.uniform(k_cam, (num_rays,))  # uniform area on the hemisphere
  az = jax.random.uniform(k_az, (num_rays,), maxval=2 * jnp.pi)
  r_xy = jnp.sqrt(jnp.clip(1.0 - z ** 2, 0.0, 1.0))
  pos = radius * jnp.stack([r_xy * jnp.cos(az), r_xy * jnp.sin(az), z], -1)
  forward = -pos / radius
  up = jnp.array([0.0, 0.0, 1.0])
  right = jnp.cross(forward, up)
  right_norm = jnp.linalg.norm(right, axis=-1, keepdims=True)
  # At the pole the up vector is degenerate: any horizontal right vector works.
  right = jnp.where(right_norm > 1e-6, right / jnp.maximum(right_norm, 1e-6),
                    jnp.array([1.0, 0.0, 0.0]))
  cam_up = jnp.cross(right, forward)
  px = jax.random.uniform(k_px, (num_rays, 2), minval=-0.5, maxval=0.5) / focal_over_width
  dirs = forward + px[:, :1] * right + px[:, 1:] * cam_up
  dirs = dirs / jnp.linalg.norm(dirs, axis=-1, keepdims=True)
  return pos, dirs


def sphere_entry(origins, directions, radius: float):
  """Where each (oriented) line enters the sphere |x| = radius.

  A ray field must see the same input for every camera on the same line, so a
  ray is described by its entry point and its direction. Lines that miss the
  sphere use the point closest to the centre, which is continuous with the
  tangent case. origins, unit directions [..., 3] -> t_entry [...] (signed
  distance along the ray; negative for a camera inside the sphere), entry
  points [..., 3] and the hit mask [...].
  """
  b = (origins * directions).sum(-1)
  c = (origins ** 2).sum(-1) - radius ** 2
  disc = b ** 2 - c
  hit = disc >= 0
  # Double where: sqrt's gradient at 0 is inf, and inf * 0 would make NaN
  # gradients for tangent and missing lines.
  safe = jnp.where(disc > 0, disc, 1.0)
  t_entry = -b - jnp.where(disc > 0, jnp.sqrt(safe), 0.0)
  return t_entry, origins + t_entry[..., None] * directions, hit


def ndc_rays(origins, directions, height: int, width: int, focal: float, near: float = 1.0):
  """World rays of a forward-facing camera -> rays in normalised device
  coordinates (NeRF's LLFF convention: the camera looks down -z, the scene
  lies beyond z = -near, and depth to infinity maps to NDC z in [-1, 1]).

  Each origin is first moved along its ray to the plane z = -near. In NDC a
  ray is o' + t d' with t in [0, 1] from the near plane to infinity (d' is not
  unit length; the scale is irrelevant for a learned density). World rays
  [..., 3] (any direction scale, d_z < 0) of a camera of height x width
  pixels and focal length `focal` -> NDC origins, directions [..., 3] (the
  input's array type).
  """
  xp = jnp if isinstance(origins, jax.Array) else np
  t = -(near + origins[..., 2]) / directions[..., 2]
  o = origins + t[..., None] * directions
  ax, ay = -2.0 * focal / width, -2.0 * focal / height
  o_ndc = xp.stack([ax * o[..., 0] / o[..., 2], ay * o[..., 1] / o[..., 2],
                    1.0 + 2.0 * near / o[..., 2]], -1)
  d_ndc = xp.stack([ax * (directions[..., 0] / directions[..., 2] - o[..., 0] / o[..., 2]),
                    ay * (directions[..., 1] / directions[..., 2] - o[..., 1] / o[..., 2]),
                    -2.0 * near / o[..., 2]], -1)
  return o_ndc, d_ndc
