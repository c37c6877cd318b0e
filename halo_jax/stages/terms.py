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
from typing import Any, Callable, NamedTuple, Optional

import jax
import jax.numpy as jnp
import numpy as np

from halo_jax import (geometry, losses, metrics, parallel, ray_fields, raycast, registry, rng,
                      samplers)
from halo_jax.stages import lo_targets, microbatch


class Inputs(NamedTuple):
  """What a term sees in a step: parameters ({'nerf', ...}), the model, the
  renders (a list, first pass first), the batch (origins, dirs [B, 3], idx
  [B], times or None), the device data (each prepared term's under its
  name), keys for rays a term draws itself, the micro-batch part, the mesh,
  the bounds, the background, the guide (a trained ray field) or None, and
  what else a trainer hands its own terms (`extra`)."""
  params: Any
  model: Any
  outs: list
  batch: dict
  data: dict
  keys: tuple
  part: Any
  mesh: Any
  near: float
  far: float
  white: bool
  guide: Any
  extra: Any = None


@dataclasses.dataclass(frozen=True)
class Term:
  """active(cfg) -> bool; weight(cfg, step) -> scalar (may be traced);
  value(Inputs, cfg) -> (loss, aux dict); needs(cfg) -> stage names;
  prepare(setup) -> dict of arrays put on device under the term's name, or
  None (setup: a terms.Setup)."""
  active: Callable
  weight: Callable
  value: Callable
  needs: Callable = lambda cfg: ()
  prepare: Optional[Callable] = None
  geometries: frozenset = geometry.ALL


class Setup(NamedTuple):
  """What `prepare` gets: the run config, the stage config, the dataset, the
  flat training rays (numpy), and finished stages' states."""
  config: Any
  cfg: Any
  dataset: Any
  rays: dict
  states: dict


TERMS = registry.Registry[Term]("loss term")


def active_terms(cfg):
  """[(name, Term)] of the terms `cfg` switches on, in registry order."""
  return [(n, t) for n, t in TERMS.items() if t.active(cfg)]


# --- L_consist (3D joint sampler): the ray field trained in the stage follows
# the frozen Lo-NeRF's depth and opacity on the training rays (L_ray's form).

def _consist_prepare(s: Setup):
  lo = s.states["lo"]
  return lo_targets.on_rays(lo, s.rays["origins"], s.rays["dirs"],
                            num_samples=lo.config.lo.sampler.num_samples,
                            near=s.dataset.near, far=s.dataset.far,
                            white_background=s.dataset.white_background,
                            target=s.config.ray.depth_target, chunk=s.config.eval.chunk,
                            block_rays=s.config.eval.block_rays)


def _consist_value(x: Inputs, cfg):
  depth, acc = raycast.ray_field_depth(x.guide, x.batch["origins"], x.batch["dirs"])
  t = x.data["consist"]
  idx = x.batch["idx"]
  value = losses.ray_field(depth, acc, t["depth"][idx], t["acc"][idx], x.far)
  return value, {"consist": value}


TERMS.register("consist", Term(
    active=lambda cfg: (cfg.kind == "radiance"
                        and samplers.SAMPLERS.get(cfg.sampler.kind).trains_guide),
    weight=lambda cfg, step: cfg.joint.consist_weight,
    value=_consist_value, needs=lambda cfg: ("lo",), prepare=_consist_prepare,
    geometries=geometry.SPATIAL))


# --- L_empty: Hi-NeRF's opacity on random rays the frozen Lo-NeRF sees empty.

def _empty_prepare(s: Setup):
  e, ds = s.cfg.empty, s.dataset
  bank = lo_targets.random_ray_bank(
      s.states["lo"], e.bank_rays, ray_fields.guide_radius(s.config.ray, ds),
      ds.train.focal / ds.train.width, ds.near, ds.far,
      ds.white_background, e.num_samples, rng.stream_seed(s.config.seed, rng.Stream.EMPTY_BANK),
      chunk=s.config.eval.chunk,
      block_rays=s.config.eval.block_rays)
  idx = np.flatnonzero(bank["acc"] < e.tau).astype(np.int32)
  if idx.size == 0:  # nothing is empty: the mask in L_empty makes it 0
    idx = np.arange(bank["acc"].shape[0], dtype=np.int32)
  out = {k: bank[k] for k in ("origins", "dirs", "acc", "times") if k in bank}
  out["idx"] = idx
  return out


def _empty_value(x: Inputs, cfg):
  e, bank = cfg.empty, x.data["empty"]
  k_pick, k_samples = x.keys
  j = bank["idx"][jax.random.randint(k_pick, (e.num_rays,), 0, bank["idx"].shape[0])]
  keys = microbatch.part_of(jax.random.split(k_samples, e.num_rays), x.part)
  j = parallel.shard_batch(microbatch.part_of(j, x.part), x.mesh)
  times = bank["times"][j] if "times" in bank else None
  t = jax.vmap(lambda k: samplers.stratified(k, x.near, x.far, e.num_samples))(keys)
  acc = raycast.composite(x.model, x.params["nerf"], bank["origins"][j], bank["dirs"][j], t,
                          x.white, times=times)["acc"]
  value = losses.empty_space(acc, bank["acc"][j], e.tau)
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
  target = x.batch["rgb"]
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
