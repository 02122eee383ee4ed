"""ogacq.cli.text_out held to rich itself: whatever it writes without rich is, byte
for byte, what rich's console writes for the same line or table at the same width;
what it cannot vouch for, rich writes."""

from __future__ import annotations

import contextlib
import io
import random

import pytest
from rich.cells import cell_len
from rich.console import Console
from rich.errors import MarkupError
from rich.markup import escape as rich_escape

from ogacq.cli import text_out
from ogacq.cli.app import main
from ogacq.cli.text_out import (
    _ONE_CELL,
    CannotVouch,
    TextTable,
    escape,
    markup_text,
    out,
    plain_width,
    wrapped,
)
from ogacq.io.tables import write_readings
from tests.diagnose.campaigns import layout, simulate
from tests.diagnose.test_diagnose_cli import MACHINE_TOML

TAGS = ["[bold]", "[yellow]", "[red]", "[green]", "[/]", "[/bold]", "[/yellow]", "[bold red]",
        "[/bold red]"]
LITERALS = ["[1]", "[x", "]", "\\[bold]", "\\\\", "\\", "[/nothing]", "[a=b]", "[@click]"]
PIECES = ["µm", "±", "→", "0.0022", "chi2(63)", "p = 4.1e-49;", "joint_offset.x", "`ogacq",
          "diagnose`", "—", "(", ")", "x", "ab", "abcdefghijklmnopqrstuvwxyz0123456789"]


def rich_text(item: str | TextTable, width: int) -> str:
    """What ogacq's rich console (ogacq.cli.plain.console) writes to a file or a pipe."""
    buffer = io.StringIO()
    console = Console(file=buffer, width=width, emoji=False, highlight=False,
                      force_terminal=False)
    console.print(item.to_rich() if isinstance(item, TextTable) else item)
    return buffer.getvalue()


def our_text(item: str | TextTable, width: int) -> str:
    lines = item.lines(width) if isinstance(item, TextTable) else \
        wrapped(markup_text(item), width)
    return "".join(line + "\n" for line in lines)


def random_words(rng: random.Random, count: int, markup: bool) -> str:
    words = []
    for _ in range(count):
        kind = rng.random()
        if markup and kind < 0.15:
            words.append(rng.choice(TAGS))
        elif markup and kind < 0.22:
            words.append(rng.choice(LITERALS))
        else:
            words.append(rng.choice(PIECES))
        words.append(rng.choice([" ", " ", " ", "", "  ", "\n", "   "]))
    return "".join(words)


def test_one_cell_characters_are_one_cell_for_rich():
    assert all(cell_len(c) == 1 for c in _ONE_CELL)


def test_escape_is_riches():
    rng = random.Random(3)
    for _ in range(300):
        text = random_words(rng, rng.randint(0, 8), markup=True)
        assert escape(text) == rich_escape(text)


def test_markup_lines_are_written_as_rich_writes_them():
    rng = random.Random(1)
    compared = 0
    for _ in range(600):
        width = rng.randint(5, 120)
        line = random_words(rng, rng.randint(0, 30), markup=rng.random() < 0.7)
        if rng.random() < 0.2:
            line = " " * rng.randint(1, 4) + line
        try:
            expected = rich_text(line, width)
        except MarkupError:
            with pytest.raises(CannotVouch):
                our_text(line, width)
            continue
        try:
            ours = our_text(line, width)
        except CannotVouch:
            continue
        assert ours == expected, (line, width)
        compared += 1
    assert compared > 300  # the cases this module takes, not the ones it leaves


def random_table(rng: random.Random) -> TextTable:
    table = TextTable(title=random_words(rng, rng.randint(1, 8), False).replace("\n", " ")
                      if rng.random() < 0.3 else None,
                      show_edge=False, header_style="bold", pad_edge=rng.random() < 0.5)
    columns = rng.randint(1, 6)
    for _ in range(columns):
        table.add_column(random_words(rng, rng.randint(0, 3), False),
                         justify=rng.choice(["left", "right", "center"]),
                         overflow=rng.choice(["fold", "ellipsis"]))
    for _ in range(rng.randint(0, 5)):
        cells = [random_words(rng, rng.randint(0, 3), rng.random() < 0.3)
                 for _ in range(rng.randint(1, columns))]
        table.add_row(*cells)
    return table


def test_tables_are_drawn_as_rich_draws_them():
    rng = random.Random(2)
    compared = left_to_rich = 0
    for _ in range(400):
        table = random_table(rng)
        width = rng.randint(30, 220)
        try:
            expected = rich_text(table, width)
        except MarkupError:
            continue
        try:
            ours = our_text(table, width)
        except CannotVouch:
            left_to_rich += 1
            continue
        assert ours == expected, (table, width)
        compared += 1
    assert compared > 200  # shrunk or not; a column squeezed below its padding is rich's


def test_the_output_goes_to_rich_where_it_cannot_vouch(capsys, monkeypatch):
    monkeypatch.setenv("COLUMNS", "40")
    wide = TextTable(show_edge=False)
    for header in ("a long header here", "another long header", "and a third"):
        wide.add_column(header)
    wide.add_row("x", "y", "z")
    for item in (wide, "wide → 世界 characters", "[bold]closed twice[/][/]"):
        try:
            expected = rich_text(item, 40)
        except MarkupError:
            with pytest.raises(MarkupError):
                out.print(item)
            continue
        out.print(item)
        assert capsys.readouterr().out == expected


def test_plain_only_where_rich_prints_plain(monkeypatch):
    for name in ("TTY_COMPATIBLE", "FORCE_COLOR", "COLUMNS"):
        monkeypatch.delenv(name, raising=False)
    monkeypatch.setenv("COLUMNS", "97")
    assert plain_width() == 97  # not a terminal (pytest captures stdout)
    monkeypatch.setenv("FORCE_COLOR", "1")
    assert plain_width() is None
    monkeypatch.setenv("FORCE_COLOR", "")
    assert plain_width() == 97
    monkeypatch.setenv("TTY_COMPATIBLE", "1")
    assert plain_width() is None
    monkeypatch.setenv("TTY_COMPATIBLE", "0")
    monkeypatch.setenv("FORCE_COLOR", "1")
    assert plain_width() == 97


@pytest.fixture(scope="module")
def campaigns(tmp_path_factory):
    root = tmp_path_factory.mktemp("text_out")
    (root / "m.toml").write_text(MACHINE_TOML)
    for name, effects in (("clean", {}), ("two", {"squareness.xy": 0.4, "backlash.z": 0.02}),
                          ("lengths", {"leg_length.y": 0.3})):
        obs = simulate(effects, 1, lay=layout(cycles=3))
        write_readings(root / f"{name}.csv", obs.layout, obs.values)
    return root


def handed_to_rich(self: object, item: object) -> None:
    raise AssertionError(f"handed to rich: {item!r}"[:200])


@pytest.mark.parametrize("columns", ["80", "120", "52"])
@pytest.mark.parametrize("command", [["refit"], ["refit", "--params", "both"], ["diagnose"]])
def test_refit_and_diagnose_write_what_rich_writes(campaigns, capsys, monkeypatch, command,
                                                   columns):
    monkeypatch.setenv("COLUMNS", columns)
    for name in ("clean", "two", "lengths"):
        words = [*command, str(campaigns / f"{name}.csv"), "-m", str(campaigns / "m.toml")]
        with monkeypatch.context() as ours_only:  # every print of the account is ours
            ours_only.setattr(text_out.TextOutput, "rich_print", handed_to_rich)
            assert main(words) == 0
        ours = capsys.readouterr().out
        with monkeypatch.context() as rich_only:
            rich_only.setattr(text_out, "plain_width", lambda: None)
            assert main(words) == 0
            assert capsys.readouterr().out == ours, (name, columns)


@pytest.mark.parametrize("line", ["[foo  bar]x[/foo bar]", "[bold  red]x[/bold red]",
                                  "[bold ]x[/bold]", "[@click]x[/]", "[@click=f(]x[/]",
                                  "[/]x", "[red]x[/bold]", "[b]x[/bold]"])
def test_markup_it_takes_is_markup_rich_takes(line):
    """Closing tags matched more strictly than rich matches them: a line rich refuses is
    never printed here."""
    try:
        expected = rich_text(line, 80)
    except MarkupError:
        with pytest.raises(CannotVouch):
            our_text(line, 80)
        return
    with contextlib.suppress(CannotVouch):  # or rich prints it
        assert our_text(line, 80) == expected
