"""The stage graph of a config: which sections are stages, and the order
their trainers' declared needs imply."""
from halo_jax import registry
from halo_jax.stages import base


def stage_names(config) -> tuple:
  """The config's stage sections (those with a trainer `kind` and `steps`)."""
  return tuple(k for k, v in config.items()
               if hasattr(v, "get") and "kind" in v and "steps" in v)


def parse_stages(spec, config) -> tuple:
  """'lo,hi' (or a list) -> ('lo', 'hi'); ConfigError for an unknown name."""
  names = tuple(s.strip() for s in (spec.split(",") if isinstance(spec, str) else spec)
                if s.strip())
  known = stage_names(config)
  bad = [s for s in names if s not in known]
  registry.check(not bad and bool(names),
                 f"config.stages={spec!r}: each stage must be one of {list(known)}")
  return names


def needed(config, stage_list=None) -> tuple:
  """Every stage the requested ones (default config.stages) need, each after
  the stages it reads (a depth-first order over `requires`)."""
  order, visiting = [], set()
  known = stage_names(config)

  def visit(name, path):
    registry.check(name in known, f"{path[-1] if path else 'config.stages'} needs stage "
                   f"{name!r}, which this config does not have (stages: {list(known)})")
    if name in order:
      return
    registry.check(name not in visiting,
                   f"stages {' -> '.join(path + [name])} need each other in a cycle")
    visiting.add(name)
    for dep in base.trainer_of(config, name).requires(config, name):
      visit(dep, path + [name])
    visiting.discard(name)
    order.append(name)

  for name in parse_stages(config.stages if stage_list is None else stage_list, config):
    visit(name, [])
  return tuple(order)
