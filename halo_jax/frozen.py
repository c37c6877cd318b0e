"""A run's config as one immutable value: composed once (scene, method,
overrides, then the protocol resolved: configure.load and protocol.resolve),
frozen, and handed to the stages, so that a write after that point raises.
What the run learns before a stage starts (the frequency search's encoding,
a self-measuring stage's share of the budget) makes a new value
(`replaced`); the run's value is never edited."""
from typing import Any, Dict

import ml_collections

Frozen = ml_collections.FrozenConfigDict


def freeze(config) -> Frozen:
  """`config` as an immutable value (itself where it already is one)."""
  return config if isinstance(config, Frozen) else Frozen(config)


def thaw(config) -> ml_collections.ConfigDict:
  """A mutable deep copy of a (frozen or not) config."""
  return ml_collections.ConfigDict(config if isinstance(config, Frozen) else config.to_dict())


def replaced(config, fields: Dict[str, Any]) -> Frozen:
  """A new frozen config: `config` with each dotted field of `fields` set
  (KeyError naming a field that does not exist)."""
  out = thaw(config)
  for dotted, value in fields.items():
    set_field(out, dotted, value)
  return freeze(out)


def set_field(config, dotted: str, value):
  """config.<dotted> = value on a mutable config; KeyError naming the field
  when it does not exist."""
  *parents, leaf = dotted.split(".")
  node = config
  for p in parents:
    node = node[p]
  if leaf not in node:
    raise KeyError(f"config has no field {dotted!r}")
  node[leaf] = value
