"""The pieces the page's tables are made of: plain strings, badges and multi-line
cells, laid out by the template."""

from __future__ import annotations

from collections.abc import Sequence
from typing import NamedTuple


class Badge(NamedTuple):
    text: str
    kind: str  # ok, warn, bad or info: its colour


class Lines(NamedTuple):
    """A table cell of several lines."""
    lines: tuple[str, ...]


Cell = str | Badge | Lines


class Table(NamedTuple):
    header: tuple[str, ...] | None  # None: the first column names the rows
    rows: list[list[Cell]]
    numeric: tuple[bool, ...]  # per column: right-aligned figures
    row_kinds: tuple[str, ...] = ()  # per row: "" or a badge kind that marks the row


def table(header: Sequence[str] | None, rows: list[list[Cell]],
          numeric: Sequence[bool] = (), row_kinds: Sequence[str] = ()) -> Table:
    width = len(header) if header else max((len(r) for r in rows), default=0)
    return Table(tuple(header) if header else None, rows,
                 tuple(numeric) + (False,) * (width - len(numeric)), tuple(row_kinds))
