"""Methods as data: each is a function from a scene's config (HALO's protocol,
as configs/<dataset>.py builds it) to the config of that method on the same
scene: which stages it trains and, per stage, its model, sampler and loss
terms. The pipeline runs whatever the config says; adding a method is a
module here plus one `register` line below, never an edit to the pipeline.

  c = methods.apply(configs.blender.get_config("lego_8view_cpu"), "freenerf")

halo_jax/configure.py is the one place a launch does this (then sets the
command line's overrides).
"""
import copy

from halo_jax import datasets, geometry, registry
from halo_jax.methods import (freenerf, halo, halo_authors, halo_auto, halo_freenerf, halo_joint,
                              halo_unseen, nerf_paper, nerf_tuned)
from halo_jax.methods.base import Method

# In the order tables list them.
METHODS = registry.Registry[Method]("method")
METHODS.register("nerf_paper", nerf_paper.METHOD)
METHODS.register("nerf_tuned", nerf_tuned.METHOD)
METHODS.register("freenerf", freenerf.METHOD)
METHODS.register("halo", halo.METHOD)
METHODS.register("halo+freenerf", halo_freenerf.METHOD)
METHODS.register("halo+unseen", halo_unseen.METHOD)
METHODS.register("halo_auto", halo_auto.METHOD)
METHODS.register("halo_joint", halo_joint.METHOD)
METHODS.register("halo_authors", halo_authors.METHOD)


def with_role(*roles) -> tuple:
  """The registered methods whose `role` is one of `roles`, in table order."""
  return tuple(n for n, m in METHODS.items() if m.role in roles)

def apply(config, name: str):
  """A copy of the scene config `config` turned into method `name` (METHODS).

  A method is applied once, to a scene's config as its file builds it:
  making a config that is already one method into another would carry the
  first one's settings into the second (HALO's into a baseline). That is
  refused; make each method from the scene's config (configure.as_method).
  """
  done = config.get("method", "")
  if done:
    raise ValueError(f"this config is already method {done!r}; make {name!r} from the "
                     "scene's config (halo_jax.configure.as_method)")
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


__all__ = ["METHODS", "Method", "apply", "with_role"]
