"""Name -> constructor tables (as multinerf's `dataset_dict`) and the error a
bad name raises.

Datasets, models, samplers, loss terms, stage trainers and methods each keep
one `Registry`; a new one is a module plus a `register` call, never a branch
in shared code.
"""
from typing import Dict, Generic, Iterator, TypeVar

T = TypeVar("T")


class ConfigError(ValueError):
  """A config field has a bad value or a combination cannot work; the message
  names the field(s) and what is allowed."""


class Registry(Generic[T]):
  """A dict from name to entry that names the config field on a miss."""

  def __init__(self, what: str):
    self.what = what
    self._entries: Dict[str, T] = {}

  def register(self, name: str, entry: T = None):
    """register(name, entry), or @register(name) as a decorator."""
    def add(e):
      if name in self._entries:
        raise ValueError(f"{self.what} {name!r} is registered twice")
      self._entries[name] = e
      return e
    return add if entry is None else add(entry)

  def get(self, name: str, field: str = "") -> T:
    """The entry called `name`; ConfigError naming `field` if there is none."""
    if name not in self._entries:
      where = f"{field}={name!r}" if field else f"{self.what} {name!r}"
      raise ConfigError(f"{where} is not a known {self.what}; use one of {sorted(self._entries)}")
    return self._entries[name]

  def names(self):
    """Names in the order they were registered."""
    return list(self._entries)

  def items(self):
    return list(self._entries.items())

  def __contains__(self, name) -> bool:
    return name in self._entries

  def __iter__(self) -> Iterator[str]:
    return iter(list(self._entries))


def check(ok: bool, message: str) -> None:
  """Raises ConfigError(message) unless ok."""
  if not ok:
    raise ConfigError(message)


__all__ = ["ConfigError", "Registry", "check"]
