"""A run's config as one immutable value: composed once (scene, method,
overrides, derived fields, then the protocol resolved: configure.compose),
frozen, and handed to the stages, so that a write after that point raises.
What the run learns before a stage starts (the frequency search's encoding,
a self-measuring stage's share of the budget) makes a new value
(`replaced`); the run's value is never edited."""
import copy
import difflib
from typing import Any, Dict

import ml_collections

Frozen = ml_collections.FrozenConfigDict


def freeze(config) -> Frozen:
  """`config` as an immutable value (itself where it already is one)."""
  return config if isinstance(config, Frozen) else Frozen(config)


def thaw(config) -> ml_collections.ConfigDict:
  """A mutable deep copy of a (frozen or not) config."""
  if isinstance(config, Frozen):
    # ConfigDict(frozen) shares its nested sections with the frozen value's
    # own unfrozen copy, which later thaws of the whole config read: editing
    # a thawed section would edit every later thaw (ml_collections 1.x)
    return copy.deepcopy(ml_collections.ConfigDict(config))
  return ml_collections.ConfigDict(config.to_dict())


def replaced(config, fields: Dict[str, Any]) -> Frozen:
  """A new frozen config: `config` with each dotted field of `fields` set
  (KeyError naming a field that does not exist)."""
  out = thaw(config)
  for dotted, value in fields.items():
    set_field(out, dotted, value)
  return freeze(out)


def _leaves(node, prefix=""):
  for key in node.keys():
    value = node[key]
    path = f"{prefix}{key}"
    yield path
    if hasattr(value, "keys"):
      yield from _leaves(value, path + ".")


def unknown_field(config, dotted: str) -> KeyError:
  """KeyError naming `dotted` and the config's nearest field names."""
  near = difflib.get_close_matches(dotted, list(_leaves(config)), n=3, cutoff=0.6)
  hint = f"; nearest: {', '.join(near)}" if near else ""
  return KeyError(f"config has no field {dotted!r}{hint}")


def get_field(config, dotted: str):
  """config.<dotted>; KeyError naming the field (and the nearest ones)."""
  node = config
  for part in dotted.split("."):
    if not hasattr(node, "keys") or part not in node:
      raise unknown_field(config, dotted)
    node = node[part]
  return node


def set_field(config, dotted: str, value):
  """config.<dotted> = value on a mutable config; KeyError naming the field
  (and the nearest ones) when it does not exist."""
  *parents, leaf = dotted.split(".")
  node = config
  for p in parents:
    if not hasattr(node, "keys") or p not in node:
      raise unknown_field(config, dotted)
    node = node[p]
  if not hasattr(node, "keys") or leaf not in node:
    raise unknown_field(config, dotted)
  node[leaf] = value
