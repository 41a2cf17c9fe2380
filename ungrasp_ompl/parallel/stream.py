"""Results streamed to a CSV file as they arrive, so that an interrupted campaign can be resumed.

A :class:`RowStream` appends one CSV row per finished task and flushes it at once: a campaign
killed half-way leaves every finished task's row on disk (at worst a last line cut short,
which is dropped on reading). Opened with ``resume``, it reads the rows already there, which
the campaign skips; without, it starts the file afresh. When the campaign ends it rewrites
the file whole and atomically, its rows in task order (:meth:`RowStream.finish`).

Rows are lists of strings, as the csv module reads them, so a row read back is written again
unchanged: a resumed campaign ends with the same file as one run in one go.
"""

from __future__ import annotations

import csv
import io
import os
from collections.abc import Sequence
from pathlib import Path
from typing import TextIO

from ..errors import InputError
from ..io import write_text_atomic


class RowStream:
    """A CSV file of result rows: header, then one row per task, keyed by its first key_columns cells."""

    def __init__(self, path: str | os.PathLike[str], header: Sequence[str], key_columns: int,
                 resume: bool = False) -> None:
        self.path = Path(path)
        """The CSV file (its directory is made when missing)."""
        self.header = list(header)
        """The column names."""
        self.key_columns = key_columns
        """How many leading columns identify a task (count)."""
        self.rows: dict[tuple[str, ...], list[str]] = {}
        """The rows so far by key: those read back on resume and those appended since."""
        if resume and self.path.is_file():
            self._read()
        self._file: TextIO | None = None

    def _read(self) -> None:
        with open(self.path, newline="") as f:
            lines = list(csv.reader(f))
        if not lines or lines[0] != self.header:
            raise InputError("resume", f"{self.path} was not written by this command (its columns differ)")
        for row in lines[1:]:
            if len(row) == len(self.header):  # a last line cut short by an interruption is dropped
                self.rows[self.key(row)] = row

    def key(self, row: Sequence[str]) -> tuple[str, ...]:
        """A row's key: its first key_columns cells."""
        return tuple(row[:self.key_columns])

    def open(self) -> "RowStream":
        """Write the header and the rows kept so far, then stand ready to append."""
        write_text_atomic(self.path, _csv_text([self.header, *self.rows.values()]))
        self._file = open(self.path, "a", newline="")
        return self

    def append(self, row: Sequence[object]) -> list[str]:
        """Add a row (cells as text; None as empty), on disk at once; returns it as text."""
        text = ["" if v is None else str(v) for v in row]
        if len(text) != len(self.header):
            raise ValueError(f"a row of {len(text)} cells for {len(self.header)} columns")
        self.rows[self.key(text)] = text
        assert self._file is not None, "open() first"
        self._file.write(_csv_text([text]))
        self._file.flush()
        return text

    def finish(self, order: Sequence[tuple[str, ...]]) -> None:
        """Close the stream and rewrite the file atomically with its rows in the keys' order
        (rows of other keys, left from an earlier campaign, are dropped)."""
        self.close()
        write_text_atomic(self.path, _csv_text([self.header, *(self.rows[k] for k in order if k in self.rows)]))

    def close(self) -> None:
        if self._file is not None:
            self._file.close()
            self._file = None

    def __enter__(self) -> "RowStream":
        return self.open()

    def __exit__(self, *exc) -> None:
        self.close()


def _csv_text(rows: Sequence[Sequence[object]]) -> str:
    buf = io.StringIO()
    csv.writer(buf, lineterminator="\n").writerows(rows)
    return buf.getvalue()
