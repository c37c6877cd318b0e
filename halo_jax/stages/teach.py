"""L_teach: the frozen Lo-NeRF as Hi-NeRF's teacher for the whole of Hi's run.

Once Hi-NeRF starts as Lo's copy, only L_empty (under 1% of the loss) and,
on static scenes, the ray field's window hold it to Lo; on D-NeRF scenes Hi's
held-out PSNR peaks half-way and falls while its training PSNR rises
(docs/notes/2026-11-28-keep-lead.md). This term renders random rays from
cameras on the hemisphere (at random times on a dynamic scene), as L_empty
does, and asks Hi's expected depth and opacity to agree with Lo's (L_ray's
form, losses.ray_field) on the rays where Lo is confident:
- opaque: Lo's opacity at least `acc_min`;
- consistent: Lo renders the same ray at a nearby time (`time_step`, dynamic
  scenes) or a nearby direction (`jitter`, radians, static scenes) opaque too,
  with its depth within `depth_tol` of the near-far range.
The weight falls linearly from `weight` at Hi's first step to 0 at the step
its run ends (stages/budget.last_step), so the teacher leads early and the
training views have the last word.

Settings: Hi's `teach` section (weight 0: off; methods/halo_teach.py switches
it on). Registered as a loss term (stages.terms.TERMS).
"""
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from halo_jax import camera, geometry, losses, parallel, ray_fields, raycast, render, rng, samplers
from halo_jax.rays import Rays
from halo_jax.stages import budget, lo_targets, microbatch, terms
from halo_jax.types import Array


class TeachBank(NamedTuple):
  """Random rays [B] with the frozen Lo-NeRF's expected depth and opacity
  [B], and idx [C], the rows where Lo is confident (C >= 1; valid [C] is 0
  for the one placeholder of a bank with none)."""
  rays: Rays
  depth: Array
  acc: Array
  idx: Array
  valid: Array


def confident(acc, acc_near, depth, depth_near, acc_min: float, depth_tol: float):
  """Where a frozen field is sure of a surface: opaque on a ray and on its
  neighbour, at depths within depth_tol (a share of far - near; depths are
  normalised by the caller). All [B] -> bool [B]."""
  return (acc >= acc_min) & (acc_near >= acc_min) & (jnp.abs(depth - depth_near) <= depth_tol)


def _neighbours(rays: Rays, key, t) -> Rays:
  """The same rays a little later in time (dynamic), or turned by `jitter`
  radians about a random axis (static)."""
  if rays.times is not None:
    later = np.clip(rays.times + t.time_step, 0.0, 1.0)
    return Rays(rays.origins, rays.dirs, later.astype(np.float32))
  axis = np.array(jax.random.normal(key, rays.dirs.shape))
  axis = axis - (axis * rays.dirs).sum(-1, keepdims=True) * rays.dirs  # perpendicular to the ray
  axis = axis / np.maximum(np.linalg.norm(axis, axis=-1, keepdims=True), 1e-9)
  turned = rays.dirs * np.cos(t.jitter) + axis * np.sin(t.jitter)
  return Rays(rays.origins, (turned / np.linalg.norm(turned, axis=-1, keepdims=True))
              .astype(np.float32), None)


def _prepare(s: terms.Setup) -> TeachBank:
  """The bank and Lo's confident rows (numpy), rendered once before Hi trains."""
  t, ds, lo = s.cfg.teach, s.dataset, s.states["lo"]
  seed = rng.stream_seed(s.config.seed, rng.Stream.TEACH_BANK)
  k_rays, k_time, k_turn = jax.random.split(jax.random.PRNGKey(seed), 3)
  o, d = camera.random_hemisphere_rays(k_rays, t.bank_rays,
                                       ray_fields.guide_radius(s.config.ray, ds),
                                       ds.train.focal / ds.train.width)
  times = None
  if ds.train.times is not None:
    times = np.asarray(jax.random.uniform(k_time, (t.bank_rays, 1)), np.float32)
  rays = Rays(np.asarray(o), np.asarray(d), times)
  kw = dict(num_samples=t.num_samples, near=ds.near, far=ds.far,
            white_background=ds.white_background, target="expected",
            chunk=s.config.eval.chunk, block_rays=s.config.eval.block_rays)
  here = lo_targets.on_rays(lo, rays, **kw)
  near = lo_targets.on_rays(lo, _neighbours(rays, k_turn, t), **kw)
  span = ds.far - ds.near
  ok = np.asarray(confident(here.acc, near.acc, here.depth / span, near.depth / span,
                            t.acc_min, t.depth_tol))
  idx = np.flatnonzero(ok).astype(np.int32)
  valid = np.ones(max(idx.size, 1), np.float32)
  if idx.size == 0:  # Lo is sure nowhere: the term is 0
    idx, valid[:] = np.zeros(1, np.int32), 0.0
  return TeachBank(rays, np.asarray(here.depth), np.asarray(here.acc), idx, valid)


def weight(cfg, step):
  """teach.weight at Hi's first step, falling linearly to 0 at its last."""
  end = max(budget.last_step(cfg), 1)
  return cfg.teach.weight * jnp.clip(1.0 - step / end, 0.0, 1.0)


def _value(x: terms.Inputs, cfg):
  t, bank = cfg.teach, x.data.terms["teach"]
  k_pick, k_samples = x.keys
  # keys of their own, apart from L_empty's and L_unseen's draws
  pick = jax.random.randint(jax.random.fold_in(k_pick, 7), (t.num_rays,), 0,
                            bank.idx.shape[0])
  keys = microbatch.part_of(jax.random.split(jax.random.fold_in(k_samples, 7), t.num_rays),
                            x.part)
  pick = parallel.shard_batch(microbatch.part_of(pick, x.part), x.mesh)
  j = bank.idx[pick]
  rays = bank.rays.take(j)
  edges = jax.vmap(lambda k: samplers.stratified(k, x.near, x.far, t.num_samples))(keys)
  out = raycast.composite(x.model, x.params["nerf"], rays.origins, rays.dirs, edges, x.white,
                          times=rays.times)
  depth = render.normalized_depth(out["depth"], out["acc"])
  value = losses.ray_field(depth * bank.valid[pick], out["acc"] * bank.valid[pick],
                           bank.depth[j] * bank.valid[pick], bank.acc[j] * bank.valid[pick],
                           x.far)
  # teach_sure: the bank rays Lo is sure on (0: the term has nothing to teach)
  return value, {"teach": value, "teach_sure": jnp.sum(bank.valid)}


terms.TERMS.register("teach", terms.Term(
    active=lambda cfg: "teach" in cfg and cfg.teach.weight > 0,
    weight=weight, value=_value, needs=lambda cfg: ("lo",), prepare=_prepare,
    # random rays from cameras on the hemisphere around the object, as L_empty's
    geometries=frozenset({geometry.Geometry.SPHERE})))
