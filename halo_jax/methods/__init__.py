"""Methods as data: each is a function from a scene's config (HALO's protocol,
as configs/<dataset>.py builds it) to the config of that method on the same
scene: which stages it trains and, per stage, its model, sampler and loss
terms. The pipeline runs whatever the config says; adding a method is a
module here plus one `register` line below, never an edit to the pipeline.

  c = methods.apply(configs.blender.get_config("lego_8view_cpu"), "freenerf")

halo_jax/configure.py's compose is the one place a launch does this, with
the user's overrides between the method's values and its derived fields.
"""
import copy

from halo_jax import datasets, frozen, geometry, registry
from halo_jax.methods import (freenerf, halo, halo_authors, halo_auto, halo_freenerf, halo_joint,
                              halo_teach, halo_unseen, nerf_paper, nerf_tuned)
from halo_jax.methods import base
from halo_jax.methods.base import Method

# In the order tables list them.
METHODS = registry.Registry[Method]("method")
METHODS.register("nerf_paper", nerf_paper.METHOD)
METHODS.register("nerf_tuned", nerf_tuned.METHOD)
METHODS.register("freenerf", freenerf.METHOD)
METHODS.register("halo", halo.METHOD)
METHODS.register("halo+freenerf", halo_freenerf.METHOD)
METHODS.register("halo+unseen", halo_unseen.METHOD)
METHODS.register("halo+teach", halo_teach.METHOD)
METHODS.register("halo_auto", halo_auto.METHOD)
METHODS.register("halo_joint", halo_joint.METHOD)
METHODS.register("halo_authors", halo_authors.METHOD)


def with_role(*roles) -> tuple:
  """The registered methods whose `role` is one of `roles`, in table order."""
  return tuple(n for n, m in METHODS.items() if m.role in roles)

def apply(config, name: str, overrides=None):
  """A copy of the scene config `config` turned into method `name` (METHODS):
  the method's table for the scene's kind (methods/base.py), its values, then
  `overrides` ({dotted field: value}), then its derived fields not
  overridden. The one order every entry point uses (configure.compose).

  A method is applied once, to a scene's config as its file builds it:
  making a config that is already one method into another would carry the
  first one's settings into the second (HALO's into a baseline). That is
  refused; make each method from the scene's config.
  """
  done = config.get("method", "")
  if done:
    raise ValueError(f"this config is already method {done!r}; make {name!r} from the "
                     "scene's config (halo_jax.configure.compose)")
  method = METHODS.get(name, "method")
  _check_scene(method, name, config.data)
  scene = copy.deepcopy(config)
  c = copy.deepcopy(config)
  rules = base.write_values(c, method.table(datasets.scene_kind(scene.data)))
  overrides = dict(overrides or {})
  for field, value in overrides.items():
    frozen.set_field(c, field, value)
  base.write_derived(c, scene, rules, skip=overrides)
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
