"""Columns shared by a printed table and a CSV file: fixed-width text and atomic CSV."""

from __future__ import annotations

import csv
import io
import textwrap
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


#: The widest printed table (characters): a terminal's width.
TABLE_WIDTH = 100
#: The most lines a column's heading is wrapped onto.
_HEADER_LINES = 3


def format_table(columns: Sequence[Column], rows: Sequence[object], width: int = TABLE_WIDTH) -> str:
    """Fixed-width text table at most width characters wide: text columns left-aligned, numbers
    right-aligned, '-' for missing. Columns missing in every row are left out; headings are
    wrapped onto up to three lines; a table still too wide is printed as blocks, one under the
    other, each repeating the leading text columns (the rows' names)."""
    if rows:
        columns = [c for c in columns if any(c.value(r) is not None for r in rows)]
    if not columns:
        return ""
    cells = [[_cell(c.value(r), c.fmt, "-") for c in columns] for r in rows]
    values = [[c.value(r) for r in rows] for c in columns]
    left = [any(isinstance(v, str) for v in vs) and all(v is None or isinstance(v, str) for v in vs) for vs in values]
    heads, widths = [], []
    for k, c in enumerate(columns):
        w = max([len(row[k]) for row in cells] + [len(word) for word in c.header.split()] + [1])
        while len(textwrap.wrap(c.header, w) or [""]) > _HEADER_LINES:
            w += 1
        heads.append(textwrap.wrap(c.header, w) or [""])
        widths.append(w)
    keys = 0  # the leading text columns name the rows: every block repeats them
    while keys < len(columns) - 1 and left[keys]:
        keys += 1
    blocks: list[list[int]] = []
    for k in range(keys, len(columns)):
        block = blocks[-1] if blocks else None
        if block is None or sum(widths[j] + 2 for j in block) + widths[k] > width:
            blocks.append(list(range(keys)))
        blocks[-1].append(k)
    if not blocks:
        blocks = [list(range(len(columns)))]
    depth = max(len(h) for h in heads)

    def line(items: Sequence[str], picked: Sequence[int]) -> str:
        return "  ".join(s.ljust(widths[j]) if left[j] else s.rjust(widths[j]) for s, j in zip(items, picked)).rstrip()

    text = []
    for picked in blocks:
        top = [[""] * (depth - len(heads[j])) + heads[j] for j in picked]  # headings end on the line above the values
        text += [line([h[i] for h in top], picked) for i in range(depth)]
        text += [line([row[j] for j in picked], picked) for row in cells]
        text.append("")
    return "\n".join(text[:-1])


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
