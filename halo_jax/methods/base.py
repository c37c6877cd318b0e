"""The Method record, apart from the registry so method modules can import it."""
import dataclasses
from typing import Protocol

from halo_jax import geometry
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
