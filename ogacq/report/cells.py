"""The pieces the page's tables are made of: plain strings, badges and multi-line
cells, laid out by the template."""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from typing import NamedTuple, TypeVar


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


V = TypeVar("V")


class Fallback(dict[str, V]):
    """A constant table (words, badge kinds, colours) that declares once what a key
    not in it reads as: ``TABLE[key]`` is ``otherwise(key)`` then."""

    def __init__(self, entries: Mapping[str, V], otherwise: Callable[[str], V]) -> None:
        super().__init__(entries)
        self.otherwise = otherwise

    def __missing__(self, key: str) -> V:
        return self.otherwise(key)


def spaced(key: str) -> str:
    """A record's key in words: ``u_input`` reads ``u input``."""
    return key.replace("_", " ")


def kinds(entries: Mapping[str, str], otherwise: str = "info") -> Fallback[str]:
    """Badge kinds by a state's word (``otherwise`` for another word)."""
    return Fallback(entries, lambda _: otherwise)
