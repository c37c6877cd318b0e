"""The one way a run's config is made: `compose(scene, method, overrides,
protocol)`, which every entry point calls (the command line, halo-compare,
halo-sweep, restore, the nerfbaselines method, the benchmark and the tests):

  c = configure.compose("configs/blender.py:lego_8view_cpu", "freenerf",
                        {"hi.sampler.num_samples": 64}, protocol=60.0)

In this order: the scene's config (configs/<dataset>.py builds a scene and
its protocol and names no method); the protocol, where one is given; the
method's table for the scene's kind (halo_jax/methods/base.py): its values,
then the overrides, then its derived fields that no override set; then the
protocol resolved once (halo_jax/protocol.py: each stage's step count and
reference clock). The result is frozen: a run's config is one value, never
edited after this point (frozen.replaced makes a new one).
"""
import importlib.util
import os

from halo_jax import config_files, frozen, methods, protocol as protocols
from halo_jax.stages import order


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


def compose(scene, method: str, overrides=None, protocol=None) -> frozen.Frozen:
  """The run's frozen config (module docstring).

  scene: a config spec ('configs/<file>.py:<variant>') or a scene ConfigDict
  (not yet a method; it is not changed); overrides: {dotted field: value};
  protocol: None (the scene's own, or as the overrides set it), 'paper',
  'steps', or a number of reference seconds (the 'budget' protocol).
  KeyError naming an unknown field and its nearest names; ConfigError for a
  protocol that does not fit the config.
  """
  base = load_scene(scene) if isinstance(scene, str) else frozen.thaw(scene)
  if protocol is not None:
    protocols.apply(base, protocol)
  c = methods.apply(base, method, overrides)
  return frozen.freeze(protocols.resolve(c, order.graph(c)))


def finish(config) -> frozen.Frozen:
  """A config edited by hand after compose (a test's, a tool's variant)
  made a run's value again: its protocol resolved, frozen."""
  c = frozen.thaw(config)
  return frozen.freeze(protocols.resolve(c, order.graph(c)))


def load(spec: str, method: str, overrides=None, protocol=None) -> frozen.Frozen:
  """compose() of a config spec."""
  return compose(spec, method, overrides, protocol)


set_field = frozen.set_field  # config.<dotted> = value, KeyError naming a missing field
