"""The Method record, apart from the registry so method modules can import it."""
import dataclasses
from typing import Any, Callable, Mapping, Protocol, Union

from halo_jax import frozen, geometry
from halo_jax.types import Config


class ApplyFn(Protocol):
  """Edits a scene's config into the method's (in place) and returns it."""
  def __call__(self, config: Config) -> Config: ...


@dataclasses.dataclass(frozen=True)
class Method:
  """summary: one line for tables and --help; apply: ConfigDict -> ConfigDict
  (edits and returns its argument); geometries: the ray geometries of the
  scenes it runs on; dynamic: whether it runs on time-dependent scenes;
  role: COMPARED (halo-compare's default and the benchmark's suites),
  REPORTED (the suites only) or "" (run on request)."""
  summary: str
  apply: ApplyFn
  geometries: frozenset = geometry.ALL
  dynamic: bool = True
  role: str = ""


COMPARED, REPORTED = "compared", "reported"


# A method's setting of one field: a value, or a function of the config as
# edited so far (a setting derived from the scene: its protocol, its sizes).
Setting = Union[Any, Callable[[Config], Any]]


def set_fields(c: Config, table: Mapping[str, Setting]) -> Config:
  """Writes each dotted field of `table` into c, in the table's order;
  KeyError naming a field that no config has."""
  for dotted, value in table.items():
    frozen.set_field(c, dotted, value(c) if callable(value) else value)
  return c


def on_top_of(first: ApplyFn, table: Mapping[str, Setting]) -> ApplyFn:
  """A method that is method `first` (its apply) with `table`'s fields set after it."""
  return lambda c: set_fields(first(c), table)
