"""Methods as data: each is a function from a scene's config (HALO's protocol,
as configs/<dataset>.py builds it) to the config of that method on the same
scene: which stages it trains and, per stage, its model, sampler and loss
terms. The pipeline runs whatever the config says; adding a method is a
module here plus one `register` line below, never an edit to the pipeline.

  c = methods.apply(configs.blender.get_config("lego_8view_cpu"), "freenerf")
"""
import copy

from halo_jax import datasets, geometry, registry
from halo_jax.methods import (freenerf, halo, halo_auto, halo_freenerf, halo_joint, halo_unseen,
                              nerf_paper, nerf_tuned)
from halo_jax.methods.base import Method

METHODS = registry.Registry[Method]("method")
# Older spellings in config variants ('<scene>_..._nerf', 'fern_4view_joint').
ALIASES = {"nerf": "nerf_tuned", "joint": "halo_joint"}
METHODS.register("halo", halo.METHOD)
METHODS.register("nerf_tuned", nerf_tuned.METHOD)
METHODS.register("nerf_paper", nerf_paper.METHOD)
METHODS.register("freenerf", freenerf.METHOD)
METHODS.register("halo+freenerf", halo_freenerf.METHOD)
METHODS.register("halo_auto", halo_auto.METHOD)
METHODS.register("halo+unseen", halo_unseen.METHOD)
METHODS.register("halo_joint", halo_joint.METHOD)

def apply(config, name: str):
  """A copy of `config` turned into method `name` (METHODS or ALIASES).

  A method is applied once, to a scene's config as its file builds it:
  making a config that is already one method into another would carry the
  first one's settings into the second (HALO's into a baseline). That is
  refused; load the scene's variant with the method's suffix instead
  (runs.load_config_as).
  """
  name = ALIASES.get(name, name)
  done = config.get("method", "")
  if done == name:
    return copy.deepcopy(config)
  if done:
    raise ValueError(f"this config is already method {done!r}; to get {name!r} on the same "
                     f"scene, load the scene's variant with the suffix _{name} "
                     "(halo_jax.runs.load_config_as)")
  method = METHODS.get(name, "method")
  _check_scene(method, name, config.data)
  c = method.apply(copy.deepcopy(config))
  c.method = name
  return c


def _check_scene(method, name, data):
  spec = datasets.spec_of(data)
  runs_on = method.geometries if method.dynamic or not spec.dynamic else frozenset()
  registry.check(spec.geometry in runs_on,
                 f"method {name!r} does not run on data.kind={data.kind!r} "
                 f"({'dynamic, ' if spec.dynamic else ''}{spec.geometry.value} rays); it runs on "
                 f"{geometry.names(method.geometries)} rays"
                 f"{'' if method.dynamic else ', static scenes only'}")


def split_variant(arg: str, flags=("cpu",)):
  """'lego_8view_cpu_nerf_paper' -> (['lego', '8view'], {'cpu'}, 'nerf_paper').

  The variant ends with an optional method name (METHODS or ALIASES; 'halo'
  when absent), before it optional flags from `flags`.
  """
  method = "halo"
  for name in sorted(list(METHODS.names()) + list(ALIASES), key=len, reverse=True):
    if arg == name or arg.endswith("_" + name):
      method, arg = ALIASES.get(name, name), arg[:-len(name)].rstrip("_")
      break
  parts, found = arg.split("_") if arg else [], set()
  while parts and parts[-1] in flags:
    found.add(parts.pop())
  return parts, found, method


__all__ = ["ALIASES", "METHODS", "Method", "apply", "split_variant"]
