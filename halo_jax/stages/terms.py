"""Loss terms of a stage, one registry entry each, for the 3D and the
light-field trainers alike (stages/epi.py registers the light-field ones).

L = L_rec (+ coarse_weight L_rec of the first pass) + sum_k w_k(step) L_k over
the active terms. A term says which config section holds its settings, when
it is active, which finished stages it reads, which ray geometries it
supports, what it renders once before training (`prepare`), and how to
compute it from a step's renders (`value`). The formulas themselves are the
pure functions of halo_jax.losses.
"""
import dataclasses
from typing import Any, Dict, NamedTuple, Optional, Protocol, Tuple, Union

import jax
import jax.numpy as jnp
import numpy as np

from halo_jax import (geometry, losses, metrics, parallel, ray_fields, raycast, registry, rng,
                      samplers)
from halo_jax.rays import Batch, Pixels, Rays
from halo_jax.types import Array, Config, Params, Tree
from halo_jax.stages import lo_targets, microbatch
from halo_jax.stages.batches import StageData


class Inputs(NamedTuple):
  """What a term sees in a step: parameters ({'nerf', ...}), the model, the
  renders (a list, first pass first), the step's rays.Batch, the stage's
  batches.StageData (each prepared term's arrays under its name), keys for
  rays a term draws itself, the micro-batch part, the mesh, the bounds, the
  background, the guide (a trained ray field) or None, and what else a
  trainer hands its own terms (`extra`)."""
  params: Params
  model: Any                # the stage's Flax field
  outs: list                # raycast.composite dicts, first pass first
  batch: Batch
  data: StageData
  keys: tuple
  part: Optional[Tuple[int, int]]
  mesh: Any                 # a jax.sharding.Mesh or None
  near: float
  far: float
  white: bool
  guide: Any                # raycast.Guide or None
  extra: Optional[Dict[str, Any]] = None


class Setup(NamedTuple):
  """What `prepare` gets: the run config, the stage config, the dataset, the
  training pixels (numpy rays.Pixels), and finished stages' states."""
  config: Config
  cfg: Config
  dataset: Any              # datasets.Dataset
  pixels: Pixels
  states: dict


class ActiveFn(Protocol):
  def __call__(self, cfg: Config) -> bool: ...


class WeightFn(Protocol):
  def __call__(self, cfg: Config, step: Array) -> Union[float, Array]: ...


class ValueFn(Protocol):
  """The term's unweighted loss (a scalar) and its aux metrics."""
  def __call__(self, x: Inputs, cfg: Config) -> Tuple[Array, Dict[str, Array]]: ...


class NeedsFn(Protocol):
  def __call__(self, cfg: Config) -> Tuple[str, ...]: ...


class PrepareFn(Protocol):
  """A pytree of arrays put on device under the term's name in
  StageData.terms (or None)."""
  def __call__(self, setup: Setup) -> Tree: ...


@dataclasses.dataclass(frozen=True)
class Term:
  """A loss term: whether a stage config switches it on, its weight at a
  step (may be traced), its value on a step's Inputs, the finished stages
  it reads, what it prepares once before training, and the ray geometries
  it works on."""
  active: ActiveFn
  weight: WeightFn
  value: ValueFn
  needs: NeedsFn = lambda cfg: ()
  prepare: Optional[PrepareFn] = None
  geometries: frozenset = geometry.ALL


TERMS = registry.Registry[Term]("loss term")


def active_terms(cfg):
  """[(name, Term)] of the terms `cfg` switches on, in registry order."""
  return [(n, t) for n, t in TERMS.items() if t.active(cfg)]


def stage_data(ctx, cfg, pixels: Pixels, active, guide=None) -> StageData:
  """The stage's StageData (numpy): its pixels, what each active term
  prepares once before training, and a frozen guide's parameters."""
  setup = Setup(ctx.config, cfg, ctx.dataset, pixels, ctx.states)
  prepared = {n: t.prepare(setup) for n, t in active if t.prepare is not None}
  return StageData(pixels, prepared, guide)


# --- L_consist (3D joint sampler): the ray field trained in the stage follows
# the frozen Lo-NeRF's depth and opacity on the training rays (L_ray's form).

def _consist_prepare(s: Setup):
  lo = s.states["lo"]
  targets = lo_targets.on_rays(lo, s.pixels.rays, num_samples=lo.config.lo.sampler.num_samples,
                               near=s.dataset.near, far=s.dataset.far,
                               white_background=s.dataset.white_background,
                               target=s.config.ray.depth_target, chunk=s.config.eval.chunk,
                               block_rays=s.config.eval.block_rays)
  return targets._replace(rays=None)  # row for row the training pixels


def _consist_value(x: Inputs, cfg):
  depth, acc = raycast.ray_field_depth(x.guide, x.batch.rays.origins, x.batch.rays.dirs)
  t = x.data.terms["consist"].take(x.batch.idx)
  value = losses.ray_field(depth, acc, t.depth, t.acc, x.far)
  return value, {"consist": value}


TERMS.register("consist", Term(
    active=lambda cfg: (cfg.kind == "radiance"
                        and samplers.SAMPLERS.get(cfg.sampler.kind).trains_guide),
    weight=lambda cfg, step: cfg.joint.consist_weight,
    value=_consist_value, needs=lambda cfg: ("lo",), prepare=_consist_prepare,
    geometries=geometry.SPATIAL))


# --- L_empty: Hi-NeRF's opacity on random rays the frozen Lo-NeRF sees empty.

class EmptyBank(NamedTuple):
  """L_empty's random rays [B] with the frozen Lo-NeRF's opacity acc [B],
  and idx [E], the rows of those Lo sees empty (acc < tau)."""
  rays: Rays
  acc: Any
  idx: Any


def _empty_prepare(s: Setup):
  e, ds = s.cfg.empty, s.dataset
  bank = lo_targets.random_ray_bank(
      s.states["lo"], e.bank_rays, ray_fields.guide_radius(s.config.ray, ds),
      ds.train.focal / ds.train.width, ds.near, ds.far,
      ds.white_background, e.num_samples, rng.stream_seed(s.config.seed, rng.Stream.EMPTY_BANK),
      chunk=s.config.eval.chunk,
      block_rays=s.config.eval.block_rays)
  idx = np.flatnonzero(bank.acc < e.tau).astype(np.int32)
  if idx.size == 0:  # nothing is empty: the mask in L_empty makes it 0
    idx = np.arange(bank.acc.shape[0], dtype=np.int32)
  return EmptyBank(bank.rays, bank.acc, idx)


def _empty_value(x: Inputs, cfg):
  e, bank = cfg.empty, x.data.terms["empty"]
  k_pick, k_samples = x.keys
  j = bank.idx[jax.random.randint(k_pick, (e.num_rays,), 0, bank.idx.shape[0])]
  keys = microbatch.part_of(jax.random.split(k_samples, e.num_rays), x.part)
  j = parallel.shard_batch(microbatch.part_of(j, x.part), x.mesh)
  rays = bank.rays.take(j)
  t = jax.vmap(lambda k: samplers.stratified(k, x.near, x.far, e.num_samples))(keys)
  noise = e.get("density_noise", 0.0)
  k_noise = jax.vmap(lambda k: jax.random.fold_in(k, 1))(keys) if noise > 0 else None
  acc = raycast.composite(x.model, x.params["nerf"], rays.origins, rays.dirs, t, x.white,
                          k_noise, noise, times=rays.times)["acc"]
  value = losses.empty_space(acc, bank.acc[j], e.tau)
  return value, {"empty": value}


TERMS.register("empty", Term(
    active=lambda cfg: "empty" in cfg and cfg.empty.weight > 0,
    weight=lambda cfg, step: jnp.where(step >= cfg.empty.start_step, cfg.empty.weight, 0.0),
    value=_empty_value, needs=lambda cfg: ("lo",), prepare=_empty_prepare,
    # random rays from cameras on the upper hemisphere around the object
    geometries=frozenset({geometry.Geometry.SPHERE})))


# --- FreeNeRF's occlusion loss: density of the samples nearest the camera.

def _occlusion_value(x: Inputs, cfg):
  value = losses.occlusion(x.outs[0]["sigma"], cfg.occlusion.num_near)
  return value, {"occlusion": value}


TERMS.register("occlusion", Term(
    active=lambda cfg: "occlusion" in cfg and cfg.occlusion.weight > 0,
    weight=lambda cfg, step: cfg.occlusion.weight,
    value=_occlusion_value, geometries=geometry.SPATIAL))


def check_geometries(cfg, name, dspec, where):
  """ConfigError for an active term the scene's ray geometry cannot take."""
  for tname, term in active_terms(cfg):
    registry.check(dspec.geometry in term.geometries,
                   f"{name}.{tname} (loss term {tname!r}) takes "
                   f"{geometry.names(term.geometries)} rays, not {where}; set its weight to 0")


def total(cfg, step, x: Inputs, terms):
  """L_rec (+ the first pass's, weighted) plus every active term: (loss, aux)."""
  target = x.batch.rgb
  rec = losses.reconstruction(x.outs[-1]["rgb"], target)
  loss = rec
  if len(x.outs) > 1:
    loss = loss + cfg.sampler.coarse_weight * losses.reconstruction(x.outs[0]["rgb"], target)
  aux = {"psnr": metrics.mse_to_psnr(rec)}
  for _, term in terms:
    value, term_aux = term.value(x, cfg)
    loss = loss + term.weight(cfg, step) * value
    aux.update(term_aux)
  return loss, aux
