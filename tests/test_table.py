"""Text tables sized to their cells."""

from __future__ import annotations

import pytest

from benchmarks.table import Column, format_table


def test_columns_fit_the_widest_cell_and_align() -> None:
    columns = (Column("controller", align="<"), Column("rms", "[mm]"))
    text = format_table(columns, [["mpc", "1.5"], ["a-much-longer-controller", "12.25"]])
    assert text.splitlines() == [
        "controller                 rms",
        "                          [mm]",
        "------------------------------",
        "mpc                        1.5",
        "a-much-longer-controller 12.25",
    ]


def test_no_unit_line_without_units_and_rows_must_fit() -> None:
    assert format_table((Column("a", align="<"),), [["x"]]).splitlines() == ["a", "-", "x"]
    with pytest.raises(ValueError, match="a row of 1 cells in a table of 2 columns"):
        format_table((Column("a"), Column("b")), [["x"]])
