"""Plain-text tables whose columns fit their widest cell (long names shift nothing)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass


@dataclass(frozen=True)
class Column:
    """A column: its title, its unit (a second header line, e.g. ``[mm]``) and alignment
    (``"<"`` for names, ``">"`` for numbers)."""

    title: str
    unit: str = ""
    align: str = ">"


def format_table(columns: Sequence[Column], rows: Sequence[Sequence[str]]) -> str:
    """The table as lines: titles, units (if any column has one), a rule, then ``rows``
    (cells already formatted as text), every column as wide as its widest cell."""
    for row in rows:
        if len(row) != len(columns):
            raise ValueError(f"a row of {len(row)} cells in a table of {len(columns)} columns")
    widths = [max([len(column.title), len(column.unit), *(len(row[i]) for row in rows)])
              for i, column in enumerate(columns)]

    def line(cells: Sequence[str]) -> str:
        return " ".join(f"{cell:{column.align}{width}}"
                        for cell, column, width in zip(cells, columns, widths, strict=True)
                        ).rstrip()

    lines = [line([column.title for column in columns])]
    if any(column.unit for column in columns):
        lines.append(line([column.unit for column in columns]))
    lines.append("-" * (sum(widths) + len(widths) - 1))
    lines.extend(line(row) for row in rows)
    return "\n".join(lines)


__all__ = ["Column", "format_table"]
