"""The one way a run's config is made: a scene, then a method, then overrides.

A config file (configs/<dataset>.py) describes a scene and its protocol; it
names no method. `as_method` turns that scene config into one method's
(halo_jax.methods: which stages, models, samplers and loss terms), once, and
then sets the command line's dotted overrides, so an override always wins
over what the method sets:

  c = configure.load("configs/blender.py:lego_8view_cpu", "freenerf",
                     {"hi.steps": 100})

The command-line entry points do the same from their --config and --method
flags (halo_jax/cli/__init__.py: config_of_flags).
"""
import importlib.util
import os

from halo_jax import config_files, frozen, methods, protocol


def load_scene(spec: str):
  """'configs/blender.py:lego_8view_cpu' -> that file's ConfigDict, as no
  method yet (the path as given, else the shipped config of that name:
  config_files.resolve)."""
  path, _, variant = config_files.resolve(spec).partition(":")
  if not os.path.exists(path):
    raise FileNotFoundError(f"config file {spec.partition(':')[0]!r} not found")
  module_spec = importlib.util.spec_from_file_location(
      "halo_config_" + os.path.basename(path)[:-3], path)
  module = importlib.util.module_from_spec(module_spec)
  module_spec.loader.exec_module(module)
  return module.get_config(variant) if variant else module.get_config()


def as_method(scene, method: str, overrides=None):
  """A copy of the scene config `scene` made into `method`, then `overrides`
  ({dotted field: value}) set, then its protocol's step counts fixed
  (halo_jax/protocol.py: what a printed or recorded config shows)."""
  c = methods.apply(scene, method)   # a copy
  for field, value in (overrides or {}).items():
    set_field(c, field, value)
  return protocol.resolve(c)


def load(spec: str, method: str, overrides=None):
  """load_scene(spec) as `method`, with `overrides` (as_method)."""
  return as_method(load_scene(spec), method, overrides)


set_field = frozen.set_field  # config.<dotted> = value, KeyError naming a missing field


