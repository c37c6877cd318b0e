"""The Method record, apart from the registry so method modules can import it."""
import dataclasses
from typing import Callable

from halo_jax import geometry


@dataclasses.dataclass(frozen=True)
class Method:
  """summary: one line for tables and --help; apply: ConfigDict -> ConfigDict
  (edits and returns its argument); geometries: the ray geometries of the
  scenes it runs on; dynamic: whether it runs on time-dependent scenes."""
  summary: str
  apply: Callable
  geometries: frozenset = geometry.ALL
  dynamic: bool = True
