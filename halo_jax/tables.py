"""Markdown tables for the commands' reports (compare, sweep, tune_frequency):
one way to write a table and a missing value."""
import math
from typing import Sequence


def cell(value, fmt: str) -> str:
  """`value` formatted with `fmt`, or '-' where it is missing (None or NaN)."""
  if value is None or (isinstance(value, float) and math.isnan(value)):
    return "-"
  return format(value, fmt)


def markdown(header: Sequence[str], rows: Sequence[Sequence[str]]) -> str:
  """A Markdown table of header [C] and rows [R][C] (strings), no trailing newline."""
  for r in rows:
    if len(r) != len(header):
      raise ValueError(f"a row has {len(r)} cells, the header {len(header)}: {r}")
  lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
  return "\n".join(lines + ["| " + " | ".join(r) + " |" for r in rows])
