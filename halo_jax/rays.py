"""Rays and the batches made of them, as typed pytrees.

Every renderer takes rays as an origin and a direction [R, 3]: 3D rays as
they are (halo_jax.camera), two-plane rays as (u, v, 0) and (s, t, 1)
(datasets/stanford_lf.py). A field `None` is an absent part (a static
scene's times), which jax treats as an empty subtree.
"""
from typing import NamedTuple, Optional

from halo_jax.types import Array


def _take(x, idx):
  return None if x is None else x[idx]


class Rays(NamedTuple):
  """origins, dirs [R, 3]; times [R, 1] for a dynamic scene, else None."""
  origins: Array
  dirs: Array
  times: Optional[Array] = None

  def take(self, idx) -> "Rays":
    """The rays at rows `idx` [B]."""
    return Rays(*(_take(x, idx) for x in self))


class Pixels(NamedTuple):
  """A stage's training pixels: their rays [R], colours rgb [R, 3], and the
  arrays stages.batches.draw reads to draw from centre crops or one view at a
  time (batches.index_data; None where a stage draws from all pixels)."""
  rays: Rays
  rgb: Array
  index: Optional[object] = None   # batches.index_data's arrays


class Batch(NamedTuple):
  """One step's training rays: rays [B], rgb [B, 3], and idx [B], their rows
  in the stage's Pixels (where per-pixel targets are looked up)."""
  rays: Rays
  rgb: Array
  idx: Array


class Targets(NamedTuple):
  """A frozen field's depth and opacity [R] on rays [R] (rays None where the
  targets belong to the stage's own training pixels, row for row)."""
  rays: Optional[Rays]
  depth: Array
  acc: Array

  def take(self, idx) -> "Targets":
    return Targets(None if self.rays is None else self.rays.take(idx), self.depth[idx],
                   self.acc[idx])
