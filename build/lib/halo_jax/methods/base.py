"""The Method record, apart from the registry so method modules can import it."""
import dataclasses
from typing import Callable


@dataclasses.dataclass(frozen=True)
class Method:
  """summary: one line for tables and --help; apply: ConfigDict -> ConfigDict
  (edits and returns its argument)."""
  summary: str
  apply: Callable
