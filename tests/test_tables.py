"""halo_jax/tables.py: the one Markdown table writer of the commands' reports."""
import math

import pytest

from halo_jax import tables


def test_markdown_table_and_missing_cells():
  text = tables.markdown(["a", "b"], [["1", tables.cell(None, ".2f")],
                                      [tables.cell(2.345, ".2f"), tables.cell(math.nan, ".1f")]])
  assert text == "| a | b |\n|---|---|\n| 1 | - |\n| 2.35 | - |"


def test_a_row_of_the_wrong_width_is_refused():
  with pytest.raises(ValueError, match="a row has 1 cells, the header 2"):
    tables.markdown(["a", "b"], [["1"]])
