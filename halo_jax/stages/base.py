"""The stage-trainer interface and its registry.

A stage config names its trainer in `kind`; the trainer says which finished
stages it reads (`requires`), which ray geometries it supports, how to build
parameters shaped like its output (to restore a finished stage), and how to
train. The pipeline (halo_jax/pipeline.py) only ever talks to this interface.
"""
import dataclasses
from typing import TYPE_CHECKING, Any, Callable, Dict, Optional, Protocol, Tuple

from halo_jax import evaluate, geometry, registry
from halo_jax.types import Array, Config, Params

if TYPE_CHECKING:  # annotations only
  from halo_jax import datasets
  from halo_jax.stages.metrics_log import MetricsLog
  from halo_jax.stages.state import StageState


@dataclasses.dataclass(frozen=True)
class StageContext:
  """Everything a trainer gets: the run config, the stage's name, the data,
  the workdir, finished stages' states by name, the metrics log, training
  seconds spent by earlier stages (reference seconds: loop.clock), the data-parallel mesh (or None), and the
  pacing.Pacer of a run driven step by step from outside (or None)."""
  config: Config
  name: str
  dataset: "datasets.Dataset"
  workdir: str
  states: Dict[str, "StageState"]
  log: Optional["MetricsLog"] = None
  wall_offset: float = 0.0
  mesh: Optional[Any] = None      # a jax.sharding.Mesh
  pacer: Optional[Any] = None     # a stages.pacing.Pacer

  @property
  def cfg(self):
    return self.config[self.name]

  @property
  def front_s(self):
    """The front's times (eval.front_s) this stage owes: those past the
    earlier stages' training on the reference clock (snapshots.py)."""
    offset = self.cfg.ref_offset_s if self.cfg.get("ref_step_s", 0.0) else self.wall_offset
    return tuple(t for t in self.config.eval.front_s if t > offset)


RenderFn = Callable[..., Dict[str, Array]]   # (origins, dirs[, times]) -> {'rgb', 'depth', ...}


class RequiresFn(Protocol):
  def __call__(self, config: Config, name: str) -> Tuple[str, ...]: ...


class ParamsLikeFn(Protocol):
  def __call__(self, config: Config, name: str, dataset: Any = None) -> Params: ...


class TrainFn(Protocol):
  def __call__(self, ctx: StageContext) -> Tuple[Any, Dict[str, Any]]: ...  # (StageState, info)


class CheckFn(Protocol):
  def __call__(self, config: Config, name: str, dspec: Any) -> None: ...


class RendererFn(Protocol):
  def __call__(self, config: Config, name: str, dataset: Any,
               states: Dict[str, Any]) -> RenderFn: ...


class GuideFn(Protocol):
  def __call__(self, config: Config, name: str, dataset: Any,
               states: Dict[str, Any]) -> Optional[Tuple[Any, Config]]: ...


@dataclasses.dataclass(frozen=True)
class Trainer:
  """requires(config, name) -> stage names it reads; params_like(config, name,
  dataset) -> a parameter pytree of its output's shape; train(StageContext)
  -> (StageState, info); check(config, name, dataset_spec) raises ConfigError
  for combinations it cannot train (run before any work); renderer(config,
  name, dataset, states) -> fn(o, d[, t]) -> {'rgb', 'depth', 'acc', ...} of
  the finished stage states[name] (None for stages that make no images);
  guide(config, name, dataset, states) -> (raycast.Guide, sampler config) of
  the ray field that places the stage's samples, or None (None: never)."""
  requires: RequiresFn
  params_like: ParamsLikeFn
  train: TrainFn
  check: CheckFn
  geometries: frozenset = geometry.ALL
  renderer: Optional[RendererFn] = None
  guide: Optional[GuideFn] = None


TRAINERS = registry.Registry[Trainer]("stage trainer")


def trainer_of(config, name: str) -> Trainer:
  return TRAINERS.get(config[name].get("kind", ""), f"{name}.kind")


def renderer_of(config, name: str, dataset, states) -> Callable:
  """The finished stage's renderer (Trainer.renderer); its models carry
  config.sin_cos, the way their sin and cos are evaluated."""
  return trainer_of(config, name).renderer(config, name, dataset, states)


def select_fn(ctx: StageContext, make_render: Callable) -> Optional[Callable]:
  """The loop's model-selection score of a stage with `select_best`:
  (params, step) -> mean PSNR over all of dataset.select, the render fn made
  by make_render(params, step); None where the stage does not select."""
  if not ctx.cfg.get("select_best", False):
    return None
  views = ctx.dataset.select
  if views is None:
    raise registry.ConfigError(f"{ctx.name}.select_best needs data.select_views: the views "
                               "that choose the parameters (never the test views)")
  chunk = ctx.config.eval.chunk
  return lambda params, step: evaluate.heldout(make_render(params, step), views, chunk,
                                               len(views.names))["psnr"]
