"""L_unseen: a radiance field kept empty where no training camera looks.

Few views leave space that no training ray crosses. Nothing in L_rec reaches
it, so whatever density the field starts with or spreads there stays, and a
held-out camera looking through it sees fog (docs/benchmark.md, `spheres`).
L_empty does not help where Lo-NeRF itself holds that fog. This term draws
points where held-out cameras look (uniform along random hemisphere rays,
between near and far; at random times on dynamic scenes), keeps those that
fewer than `min_views` training frusta hold (visibility.seen_count), and
penalises the field's mean density there (losses.unseen_density). It needs
no earlier stage, so it regularises Lo-NeRF as well as Hi-NeRF.

Settings: the stage's `unseen` section (weight 0: off). Registered as a
loss term (stages.terms.TERMS); methods/halo_unseen.py switches it on.
"""
from typing import NamedTuple, Optional

import jax
import jax.numpy as jnp
import numpy as np

from halo_jax import camera, geometry, losses, parallel, ray_fields, rng, visibility
from halo_jax.stages import microbatch, terms
from halo_jax.types import Array


class UnseenBank(NamedTuple):
  """Points [P, 3] that fewer than min_views training cameras see, the
  directions of the rays they were drawn on [P, 3], their times [P, 1]
  (dynamic scenes, else None), and valid [P]: 0 for the one placeholder of a
  scene where every point is seen (P >= 1)."""
  points: Array
  dirs: Array
  times: Optional[Array]
  valid: Array


def _prepare(s: terms.Setup) -> UnseenBank:
  """The bank of unseen points (numpy)."""
  u, ds = s.cfg.unseen, s.dataset
  seed = rng.stream_seed(s.config.seed, rng.Stream.UNSEEN_BANK)
  k_rays, k_t, k_time = jax.random.split(jax.random.PRNGKey(seed), 3)
  o, d = camera.random_hemisphere_rays(k_rays, u.bank_points,
                                       ray_fields.guide_radius(s.config.ray, ds),
                                       ds.train.focal / ds.train.width)
  t = jax.random.uniform(k_t, (u.bank_points, 1), minval=ds.near, maxval=ds.far)
  points = o + t * d
  w2c = visibility.world_to_camera(jnp.asarray(ds.train.c2w))
  seen = jax.jit(visibility.seen_count, static_argnums=(2, 3, 4))(
      points, w2c, float(ds.train.focal), int(ds.train.width), int(ds.train.height))
  keep = np.flatnonzero(np.asarray(seen) < u.min_views)
  valid = np.ones(max(keep.size, 1), np.float32)
  if keep.size == 0:
    keep, valid[:] = np.zeros(1, np.int64), 0.0
  times = None
  if ds.train.times is not None:
    times = np.asarray(jax.random.uniform(k_time, (u.bank_points, 1)))[keep]
  return UnseenBank(np.asarray(points)[keep], np.asarray(d)[keep], times, valid)


def _value(x: terms.Inputs, cfg):
  u, bank = cfg.unseen, x.data.terms["unseen"]
  k_pick, _ = x.keys
  # a key of its own, apart from L_empty's draws from the same step keys
  j = jax.random.randint(jax.random.fold_in(k_pick, 5), (u.num_points,), 0,
                         bank.points.shape[0])
  j = parallel.shard_batch(microbatch.part_of(j, x.part), x.mesh)
  extra = {} if bank.times is None else {"times": bank.times[j]}
  sigma, _ = x.model.apply({"params": x.params["nerf"]}, bank.points[j], bank.dirs[j],
                           None, 0.0, **extra)
  value = losses.unseen_density(sigma, bank.valid[j] > 0)
  return value, {"unseen": value}


terms.TERMS.register("unseen", terms.Term(
    active=lambda cfg: "unseen" in cfg and cfg.unseen.weight > 0,
    weight=lambda cfg, step: cfg.unseen.weight,
    value=_value, prepare=_prepare,
    # held-out cameras on the hemisphere around the object
    geometries=frozenset({geometry.Geometry.SPHERE})))
