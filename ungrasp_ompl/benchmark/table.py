"""Columns shared by a printed table and a CSV file: fixed-width text and atomic CSV."""

from __future__ import annotations

import csv
import io
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

from ..io import write_text_atomic


@dataclass(frozen=True)
class Column:
    """A column of a printed table and of a CSV file."""

    header: str
    """Its heading in the printed table."""
    csv_name: str
    """Its name in the CSV header."""
    value: Callable[[object], object]
    """Its value for a row (None: missing)."""
    fmt: str = ""
    """Its text format in the table (format spec); the CSV keeps full precision."""


def _cell(value: object, fmt: str, missing: str) -> str:
    if value is None:
        return missing
    if isinstance(value, bool):
        return "yes" if value else "no"
    return format(value, fmt)


def format_table(columns: Sequence[Column], rows: Sequence[object]) -> str:
    """Fixed-width text table; text columns left-aligned, numbers right-aligned, '-' for missing."""
    cells = [[_cell(c.value(r), c.fmt, "-") for c in columns] for r in rows]
    widths = [max([len(c.header)] + [len(row[k]) for row in cells]) for k, c in enumerate(columns)]
    values = [[c.value(r) for r in rows] for c in columns]
    left = [any(isinstance(v, str) for v in vs) and all(v is None or isinstance(v, str) for v in vs) for vs in values]

    def line(items: Sequence[str]) -> str:
        return "  ".join(s.ljust(w) if lft else s.rjust(w) for s, w, lft in zip(items, widths, left)).rstrip()

    return "\n".join([line([c.header for c in columns])] + [line(row) for row in cells])


def csv_values(columns: Sequence[Column], row: object) -> list[object]:
    """A row's CSV cells: full precision, booleans 0/1, empty for missing."""
    values = [c.value(row) for c in columns]
    return ["" if v is None else int(v) if isinstance(v, bool) else v for v in values]


def write_csv(path: Path, columns: Sequence[Column], rows: Sequence[object]) -> None:
    """Write rows atomically as CSV (full precision; empty for missing)."""
    buf = io.StringIO()
    writer = csv.writer(buf, lineterminator="\n")
    writer.writerow([c.csv_name for c in columns])
    writer.writerows(csv_values(columns, r) for r in rows)
    write_text_atomic(path, buf.getvalue())


__all__ = ["Column", "csv_values", "format_table", "write_csv"]
