"""The analysis commands' text output (refit, diagnose), written without rich when it
goes to a file or a pipe.

Importing rich's console and tables costs about a third of numpy's import: a good
part of a short refit. Where rich would print plain text anyway (not a terminal),
these commands' lines and tables are written here as rich 14 writes them: console
markup dropped (``rich.markup``: a tag is ``[`` then a letter, ``#``, ``/`` or ``@``;
``\\[`` is a bracket), lines soft-wrapped at the console's width as
``rich._wrap.divide_line`` breaks them, and tables in rich's HEAVY_HEAD box, their
columns at their natural widths or shrunk as ``rich.table.Table`` shrinks a table wider
than the console (``_calculate_column_widths``, ``_collapse_widths``,
``rich._ratio.ratio_reduce``). On a terminal, and wherever this module cannot vouch for
the result (a character whose width on the terminal is not one cell, markup rich would
refuse, a column squeezed below its padding, an encoding other than UTF-8, where rich
draws ASCII boxes), rich prints, as before. ``tests/cli/test_text_out.py`` holds the
two equal, byte for byte, against the rich the project installs.
"""

from __future__ import annotations

import os
import re
import sys
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Literal

if TYPE_CHECKING:
    from rich.table import Table

Justify = Literal["left", "right", "center"]

# rich.markup.RE_TAGS and rich.markup.escape's pattern (rich 13-14)
_TAG = re.compile(r"((\\*)\[([a-z#/@][^[]*?)])")
_ESCAPABLE = re.compile(r"(\\*)(\[[a-z#/@][^[]*?])")
_WORD = re.compile(r"\s*\S+\s*")  # rich._wrap.re_word
_TRAILING_SPACE = re.compile(r"\s+$")

# Characters one cell wide in every terminal and in rich's cell table, beside printable
# ASCII: the ones ogacq's output uses (units, signs, arrows, the profiles' sparkline).
_ONE_CELL = frozenset("µ±→←↑↓·°×≈≤≥−–—…²³√Δσχ▁▂▃▄▅▆▇█")

# rich.box.HEAVY_HEAD without its edges: the header's divider, the line under it, a
# body row's divider
_HEAD_DIVIDER, _HEAD_RULE, _HEAD_CROSS, _BODY_DIVIDER = "┃", "━", "╇", "│"


class CannotVouch(Exception):
    """What this module cannot render as rich would: rich prints it."""


def escape(text: str) -> str:
    """``text`` for a markup string, its tag-like brackets escaped (as
    ``rich.markup.escape``), so it prints as given."""
    def escape_backslashes(match: re.Match[str]) -> str:
        backslashes, tag = match.groups()
        return f"{backslashes}{backslashes}\\{tag}"

    text = _ESCAPABLE.sub(escape_backslashes, text)
    if text.endswith("\\") and not text.endswith("\\\\"):
        return text + "\\"
    return text


def _check_cells(text: str) -> str:
    for char in text:
        if not (" " <= char <= "~" or char == "\n" or char in _ONE_CELL):
            raise CannotVouch(f"character {char!r}")
    return text


def markup_text(markup: str) -> str:
    """The text a markup string shows, its tags dropped (``rich.markup.render``)."""
    if "[" not in markup:
        return _check_cells(markup)
    parts: list[str] = []
    open_tags: list[str] = []
    position = 0
    for match in _TAG.finditer(markup):
        full, escapes, tag = match.groups()
        start, end = match.span()
        if start > position:
            parts.append(markup[position:start].replace("\\[", "["))
        position = end
        backslashes, escaped = divmod(len(escapes), 2)
        parts.append("\\" * backslashes)
        if escaped:
            parts.append(full[len(escapes):].replace("\\[", "["))
            continue
        _follow_tag(tag.partition("=")[0], open_tags)
    if position < len(markup):
        parts.append(markup[position:].replace("\\[", "["))
    return _check_cells("".join(parts))


def _follow_tag(name: str, open_tags: list[str]) -> None:
    """Keep the open tags as rich does; a close rich would refuse is left to rich."""
    if name.startswith("@"):  # a handler rich parses (literal_eval) when it is closed
        raise CannotVouch("markup")
    if not name.startswith("/"):
        # rich matches a close by Style.normalize, which is this for a name it cannot
        # parse and at least as lenient for one it can: a match here is one for rich
        open_tags.append(name.strip().lower())
        return
    closing = name[1:].strip().lower()
    if not open_tags:
        raise CannotVouch("markup")
    if not closing:
        open_tags.pop()
        return
    if closing not in open_tags:
        raise CannotVouch("markup")
    del open_tags[len(open_tags) - 1 - open_tags[::-1].index(closing)]


def _break_offsets(line: str, width: int, fold: bool) -> list[int]:
    """Where rich breaks ``line`` to fit ``width`` cells (``rich._wrap.divide_line``):
    a word longer than a line folded, or else on a line of its own (then cut)."""
    breaks: list[int] = []
    offset = 0
    for match in _WORD.finditer(line):
        start, word = match.start(), match.group()
        length = len(word.rstrip())
        if width - offset >= length:
            offset += len(word)
        elif length > width and not fold:
            if start:
                breaks.append(start)
            offset = len(word)
        elif length > width:  # folded: chop_cells(word, width)
            chunks = [word[k:k + width] for k in range(0, len(word), width)]
            for index, chunk in enumerate(chunks):
                if start:
                    breaks.append(start)
                if index == len(chunks) - 1:
                    offset = len(chunk)
                else:
                    start += len(chunk)
        elif offset and start:
            breaks.append(start)
            offset = len(word)
    return breaks


def _justified(line: str, width: int, justify: str, overflow: str) -> str:
    """A wrapped line as ``rich.containers.Lines.justify`` then ``Text.truncate`` leave
    it."""
    if justify in ("right", "center"):
        line = _truncated(line.rstrip(), width, overflow)
        pad = width - len(line)
        left = pad if justify == "right" else pad // 2
        return " " * left + line + " " * (pad - left)
    line = _truncated(line, width, overflow)
    return line.ljust(width) if justify == "left" else line


def _truncated(line: str, width: int, overflow: str) -> str:
    if len(line) <= width:
        return line
    if overflow not in ("fold", "crop", "ellipsis"):
        raise CannotVouch(f"overflow {overflow}")
    return line[:width - 1] + "…" if overflow == "ellipsis" else line[:width]


def wrapped(text: str, width: int, justify: str = "default",
            overflow: str = "fold") -> list[str]:
    """``text`` (markup already rendered) as rich's ``Text.wrap`` lays it out."""
    if width < 1:
        raise CannotVouch("width")
    lines: list[str] = []
    for line in text.split("\n"):
        offsets = _break_offsets(line, width, fold=overflow == "fold")
        pieces = [line[a:b] for a, b in zip([0, *offsets], [*offsets, len(line)], strict=True)]
        for piece in pieces:
            if len(piece) > width:  # Text.rstrip_end
                trailing = _TRAILING_SPACE.search(piece)
                if trailing is not None:
                    piece = piece[:len(piece) - min(len(trailing.group()), len(piece) - width)]
            lines.append(_justified(piece, width, justify, overflow))
    return lines


@dataclass
class _Column:
    """A column of a TextTable: its header and how its cells are laid out."""

    header: str
    justify: Justify
    overflow: str


@dataclass
class TextTable:
    """The part of ``rich.table.Table`` the analysis output uses, drawn by this module
    or handed to rich as a rich Table."""

    title: str | None = None
    show_edge: bool = True
    header_style: str | None = None
    pad_edge: bool = True
    columns: list[_Column] = field(default_factory=list)
    rows: list[list[str]] = field(default_factory=list)

    def add_column(self, header: str = "", justify: Justify = "left",
                   overflow: str = "ellipsis") -> None:
        self.columns.append(_Column(header, justify, overflow))

    def add_row(self, *cells: str | None) -> None:
        self.rows.append(["" if cell is None else cell for cell in cells])

    def to_rich(self) -> Table:
        from rich.table import Table

        table = Table(title=self.title, show_edge=self.show_edge,
                      header_style=self.header_style, pad_edge=self.pad_edge)
        for column in self.columns:
            table.add_column(column.header, justify=column.justify,
                             overflow=column.overflow)  # type: ignore[arg-type]
        for row in self.rows:
            table.add_row(*row)
        return table

    def lines(self, width: int) -> list[str]:
        """The table as rich draws it in ``width`` cells: its columns at their natural
        widths, or shrunk as rich shrinks them and their cells wrapped; CannotVouch for
        a table with edges or a column narrower than its padding."""
        if self.show_edge or not self.columns or \
                any(len(row) > len(self.columns) for row in self.rows):
            raise CannotVouch("table")  # rich adds a column for a row's extra cell
        count = len(self.columns)
        pads = [(0 if k == 0 and not self.pad_edge else 1,
                 0 if k == count - 1 and not self.pad_edge else 1) for k in range(count)]
        rows = [[c.header for c in self.columns],
                *[[*row, *[""] * (count - len(row))] for row in self.rows]]
        texts = [[markup_text(cell) for cell in row] for row in rows]
        widths = [max(max(len(line) for line in text.split("\n")) for text in column)
                  + sum(pad) for column, pad in zip(zip(*texts, strict=True), pads,
                                                     strict=True)]
        widths = _fitted([w or 1 for w in widths], width - (count - 1))
        if any(w - left - right < 1 for w, (left, right) in zip(widths, pads, strict=True)):
            raise CannotVouch("a column narrower than its padding")
        table_width = sum(widths) + count - 1
        drawn = wrapped(markup_text(self.title), table_width, "center") if self.title else []
        for index, row in enumerate(texts):
            drawn += self._row_lines(row, widths, pads, header=index == 0)
            if index == 0:
                drawn.append(_HEAD_CROSS.join(_HEAD_RULE * w for w in widths))
        return drawn

    def _row_lines(self, row: list[str], widths: list[int], pads: list[tuple[int, int]],
                   header: bool) -> list[str]:
        cells = []
        for text, column, width, (left, right) in zip(row, self.columns, widths, pads,
                                                      strict=True):
            inner = width - left - right
            lines = wrapped(text, inner, column.justify, column.overflow)
            cells.append([" " * left + line.ljust(inner) + " " * right for line in lines])
        height = max(len(cell) for cell in cells)
        for k, width in enumerate(widths):
            blank = [" " * width] * (height - len(cells[k]))
            # rich aligns a header's cells on their last line, a body's on their first
            cells[k] = blank + cells[k] if header else cells[k] + blank
        divider = _HEAD_DIVIDER if header else _BODY_DIVIDER
        return [divider.join(cell[k] for cell in cells) for k in range(height)]


def _fitted(widths: list[int], room: int) -> list[int]:
    """The columns' widths in ``room`` cells, as rich.table.Table shrinks them: the
    widest columns first, down to the next widest, then all of them alike
    (``_calculate_column_widths``, ``_collapse_widths``, ``rich._ratio.ratio_reduce``)."""
    excess = sum(widths) - room
    while excess > 0:
        widest = max(widths)
        next_widest = max((w for w in widths if w != widest), default=0)
        if widest == next_widest or not widest:
            break
        ratios = [1 if w == widest else 0 for w in widths]
        widths = _ratio_reduce(excess, ratios, [min(excess, widest - next_widest)] * len(widths),
                               widths)
        excess = sum(widths) - room
    if excess > 0:
        widths = _ratio_reduce(excess, [1] * len(widths), widths, widths)
    return widths


def _ratio_reduce(total: int, ratios: list[int], maximums: list[int],
                  values: list[int]) -> list[int]:
    """``total`` taken from ``values`` in proportion to ``ratios``, at most ``maximums``
    each, rounded as rich rounds it (Python's round of the same quotient)."""
    ratios = [ratio if maximum else 0 for ratio, maximum in zip(ratios, maximums, strict=True)]
    total_ratio = sum(ratios)
    if not total_ratio:
        return values[:]
    result = []
    for ratio, maximum, value in zip(ratios, maximums, values, strict=True):
        if ratio and total_ratio > 0:
            taken = min(maximum, round(ratio * total / total_ratio))
            result.append(value - taken)
            total -= taken
            total_ratio -= ratio
        else:
            result.append(value)
    return result


def plain_width() -> int | None:
    """The width rich's console would print at when it prints plain text (not a
    terminal, by rich.console.Console.is_terminal's rules); None on a terminal, and
    on Windows, whose legacy console rich measures otherwise."""
    if sys.platform == "win32":
        return None
    compatible = os.environ.get("TTY_COMPATIBLE", "")
    if compatible == "1":
        return None
    if compatible != "0":
        force = os.environ.get("FORCE_COLOR")
        if force is not None:
            if force != "":
                return None
        elif _isatty(sys.stdout):
            return None
    encoding = (getattr(sys.stdout, "encoding", "utf-8") or "utf-8").lower()
    if not encoding.startswith("utf"):
        return None  # rich draws ASCII boxes
    columns = os.environ.get("COLUMNS")
    if columns is not None and columns.isdigit():
        return int(columns)
    for descriptor in (0, 1, 2):  # rich.console.Console.size
        try:
            return os.get_terminal_size(descriptor).columns or 80
        except (AttributeError, ValueError, OSError):
            continue
    return 80


def _isatty(stream: Any) -> bool:
    try:
        return bool(stream.isatty())
    except (AttributeError, ValueError):
        return False


class TextOutput:
    """``print`` as the rich console of ``ogacq.cli.plain.console`` prints a markup
    line or a TextTable, without rich wherever this module can vouch for the result."""

    def print(self, item: str | TextTable = "") -> None:
        width = plain_width()
        if width is not None:
            try:
                lines = item.lines(width) if isinstance(item, TextTable) else \
                    wrapped(markup_text(item), width)
            except CannotVouch:
                pass
            else:
                sys.stdout.write("".join(line + "\n" for line in lines))
                sys.stdout.flush()
                return
        self.rich_print(item)

    def rich_print(self, item: str | TextTable) -> None:
        from ogacq.cli.plain import console

        # a console of this moment's width and terminal, as rich's own decides them
        console().print(item.to_rich() if isinstance(item, TextTable) else item)


out = TextOutput()
