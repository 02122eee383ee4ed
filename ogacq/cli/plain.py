"""Recorded text on the terminal as it is: data, never markup, never a control sequence.

What a session, a history, a file or a device gives goes through :func:`shown` before
rich's markup (``[/3]`` in a name is text, not a closing tag) and :func:`plain` before
any other output (an escape sequence in a name does not move the cursor or retitle the
terminal). Every rich console is made by :func:`console`.
"""

from __future__ import annotations

import re
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:  # rich only where something is drawn: app.py's error line needs none
    from rich.console import Console
    from rich.progress import Progress
    from rich.table import Table

# C0 controls but tab and newline, DEL and the C1 controls (ECMA-48 5.2: the
# introducers of the terminal's escape sequences, ESC and CSI among them)
_CONTROL = re.compile(r"[\x00-\x08\x0b-\x1f\x7f-\x9f]")


def plain(value: Any) -> str:
    """``value`` as text, its control characters shown as escapes (``\\x1b``)."""
    return _CONTROL.sub(lambda m: f"\\x{ord(m.group()):02x}", str(value))


def shown(value: Any) -> str:
    """``value`` for a rich markup string or a table cell: controls shown, brackets
    escaped (rich.markup.escape), so it prints as it was recorded."""
    from rich.markup import escape

    return escape(plain(value))


def console(**options: Any) -> Console:
    """A rich console that prints emoji codes as typed (``:x:`` in an operator's name
    stays three characters) and text in the colours its markup gives, no others: rich's
    default highlighter would colour any number or quoted word of a recorded name as if
    it were code, and compiles its patterns on the first print of every command."""
    from rich.console import Console

    return Console(emoji=False, **{"highlight": False, **options})


def table_of(*columns: str, fold: bool = False, **options: Any) -> Table:
    """A table as every command draws one (no edge, bold headers) with these columns; one
    written ``">value"`` is right-justified, as format's ``>`` aligns: numbers line up.
    ``fold``: a long cell folds onto the next line, never cut."""
    from rich.table import Table

    table = Table(show_edge=False, header_style="bold", **options)
    for column in columns:
        table.add_column(column.removeprefix(">"), overflow="fold" if fold else "ellipsis",
                         justify="right" if column.startswith(">") else "left")
    return table


def bar_of(title: str, *, console: Console, transient: bool, last: bool = False) -> Progress:
    """A progress bar as every command draws one: ``title``, the bar, done of total, the
    time elapsed; ``last``: then the task's ``last`` field (the last value read)."""
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

    return Progress(TextColumn(title), BarColumn(), MofNCompleteColumn(), TimeElapsedColumn(),
                    *([TextColumn("{task.fields[last]}")] if last else []), console=console,
                    transient=transient)


class Printer:
    """``print`` through a console made at that moment: rich reads the width (the
    terminal's, ``COLUMNS``) when a console is made, and these lines are wrapped at the
    width of the moment they are printed. ``stderr``: to standard error."""

    def __init__(self, stderr: bool = False) -> None:
        self.stderr = stderr

    def print(self, *objects: Any, **options: Any) -> None:
        console(stderr=self.stderr).print(*objects, **options)


def print_wrapped(text: str) -> None:
    """A line of text on stdout as it is (no markup), wrapped between words at the
    terminal's width (80 columns to a pipe): a wider line the terminal cuts mid-word."""
    Printer().print(shown(text))
