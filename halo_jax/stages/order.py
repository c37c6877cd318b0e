"""The stage graph of a config: which sections are stages, and the order
their trainers' declared needs imply. `graph(config)` reads it once; what
validates, resolves and runs a config asks the Graph, not the config again."""
import dataclasses

from halo_jax.registry import ConfigError
from halo_jax.stages import base


@dataclasses.dataclass(frozen=True)
class Graph:
  """A config's stages, read once (names in training order).

  sections: every stage section, in config order; launch: the stages
  config.stages names; run: those and the stages they read; final: what
  config.final_stage needs, itself last; every: run and final together.
  """
  sections: tuple
  launch: tuple
  run: tuple
  final: tuple

  @property
  def every(self) -> tuple:
    return tuple(dict.fromkeys(self.run + self.final))


def stage_names(config) -> tuple:
  """The config's stage sections (those with a trainer `kind` and `steps`)."""
  return tuple(k for k, v in config.items()
               if hasattr(v, "get") and "kind" in v and "steps" in v)


def _parse(spec, known) -> tuple:
  names = tuple(s.strip() for s in (spec.split(",") if isinstance(spec, str) else spec)
                if s.strip())
  if not names or any(s not in known for s in names):
    raise ConfigError(f"config.stages={spec!r}: each stage must be one of {list(known)}")
  return names


def parse_stages(spec, config) -> tuple:
  """'lo,hi' (or a list) -> ('lo', 'hi'); ConfigError for an unknown name."""
  return _parse(spec, stage_names(config))


def _order(config, requested, known) -> tuple:
  """Every stage of `requested` and the stages it reads, each after them (a
  depth-first order over the trainers' `requires`)."""
  order, visiting = [], set()

  def visit(name, path):
    if name not in known:
      raise ConfigError(f"{path[-1] if path else 'config.stages'} needs stage {name!r}, "
                        f"which this config does not have (stages: {list(known)})")
    if name in order:
      return
    if name in visiting:
      raise ConfigError(f"stages {' -> '.join(path + [name])} need each other in a cycle")
    visiting.add(name)
    for dep in base.trainer_of(config, name).requires(config, name):
      visit(dep, path + [name])
    visiting.discard(name)
    order.append(name)

  for name in requested:
    visit(name, [])
  return tuple(order)


def needed(config, stage_list=None) -> tuple:
  """Every stage the requested ones (default config.stages) need, each after
  the stages it reads (a depth-first order over `requires`)."""
  known = stage_names(config)
  return _order(config, _parse(config.stages if stage_list is None else stage_list, known),
                known)


def graph(config) -> Graph:
  """The config's Graph; ConfigError for an unknown, missing or cyclic stage,
  or a final_stage that is not a stage section."""
  known = stage_names(config)
  launch = _parse(config.stages, known)
  run = _order(config, launch, known)
  final = config.final_stage
  if final not in known:
    raise ConfigError(f"final_stage={final!r}: must be one of {list(known)}")
  return Graph(known, launch, run, _order(config, (final,), known))
