"""What a ray is in a scene: the geometry every dataset declares.

- SPHERE: 360-degree scenes; rays are world-space (origin, unit direction)
  pairs, bounded by [near, far] in scene units, and the ray field enters
  them where they cross the cameras' sphere.
- NDC: forward-facing scenes in normalised device coordinates; rays start on
  the NDC near plane and t in [0, 1] spans near to infinity. The ray field
  reads the rays as they are (no sphere to enter).
- TWO_PLANE: light fields; a ray is (u, v) on the camera plane and (s, t) on
  the image plane, and depth along it is the EPI angle theta in
  [theta_n, theta_f] (the dataset's near, far).

Time (dynamic scenes) is an extra input on top of a geometry, not a geometry
of its own: a dataset's views carry `times` or not.
"""
import enum


class Geometry(str, enum.Enum):
  SPHERE = "sphere"
  NDC = "ndc"
  TWO_PLANE = "two_plane"


ALL = frozenset(Geometry)
SPATIAL = frozenset({Geometry.SPHERE, Geometry.NDC})


def names(geometries) -> str:
  return ", ".join(sorted(g.value for g in geometries))
