"""Every command's help says what the parser does: a flag shows no value, an example is
never cut, and every choice the help lists is one the parser accepts.

The commands come from the app's table, so a new command is checked as soon as it is
listed there. Choices are only parsed (``make_context``), never run.
"""

from __future__ import annotations

import re

import pytest

from ogacq.cli.app import EXIT_CODES, OgacqCommands, main
from ogacq.cli.lazy import LazyGroupSpec, build_command

ANSI = re.compile(r"\x1b\[[0-9;?]*[A-Za-z]")
# An option row of the help: its long name, an optional short one, and its
# choices when its type is a choice (``<a|b|c>``).
CHOICE_ROW = re.compile(r"(--[\w-]+)(?:\s+-\w)?\s+<([^<>\s]+\|[^<>\s]+)>")


def command_paths() -> list[tuple[str, ...]]:
    paths: list[tuple[str, ...]] = [()]
    for name, target in OgacqCommands.table.items():
        paths.append((name,))
        if isinstance(target, LazyGroupSpec):
            paths += [(name, sub) for sub in target.commands]
    return paths


def help_text(path: tuple[str, ...], width: int, monkeypatch, capsys) -> str:
    monkeypatch.setenv("COLUMNS", str(width))
    assert main([*path, "--help"]) == 0
    return ANSI.sub("", capsys.readouterr().out)


def one_line(text: str) -> str:
    return " ".join(text.split())


def parse_only(path: tuple[str, ...], args: list[str]) -> dict:
    """The parameters ``ogacq PATH ARGS`` would run with, without running it."""
    target = OgacqCommands.table[path[0]]
    command = build_command(path[0], target)
    if len(path) == 2:
        command = command.commands[path[1]]
    required = [p for p in command.params if p.required]
    filler: list[str] = []
    for param in required:  # any value will do: nothing is opened
        filler += ["x"] if param.param_type_name == "argument" else [param.opts[0], "x"]
    return command.make_context(" ".join(path), [*filler, *args]).params


@pytest.mark.parametrize("path", command_paths(), ids=lambda p: " ".join(p) or "ogacq")
def test_flags_show_no_value_and_examples_are_whole(path, monkeypatch, capsys):
    text = help_text(path, 80, monkeypatch, capsys)
    assert "--help" in text
    assert "<bool>" not in text
    assert "…" not in text, "a word of the help is cut at 80 columns"
    assert "4 refused as unreliable" in " ".join(text.replace("│", " ").split()), \
        "exit code 4 is documented on every help page"
    assert " ".join(EXIT_CODES.split()[:4]) in text


@pytest.mark.parametrize("path", [p for p in command_paths() if p],
                         ids=lambda p: " ".join(p))
def test_every_documented_choice_is_accepted(path, monkeypatch, capsys):
    text = help_text(path, 250, monkeypatch, capsys)
    for option, choices in CHOICE_ROW.findall(text):
        for choice in choices.split("|"):
            params = parse_only(path, [option, choice])
            name = option.removeprefix("--").replace("-", "_")
            assert str(params[name]) == choice


def test_indicators_and_profiles_are_choices_everywhere(monkeypatch, capsys):
    wizard = help_text(("wizard",), 250, monkeypatch, capsys)
    assert re.search(r"--indicators\s+<6\|2>", wizard)
    assert "2<=x<=6" not in wizard
    for command in ("demo", "sim", "wizard"):
        text = help_text((command,), 250, monkeypatch, capsys)
        assert re.search(r"--profile\s+<cia402\|", text), command
        assert re.search(r"--seed <int> .*\[default: 1; x>=0\]", one_line(text)), command


def test_a_flag_given_a_value_is_refused(capsys):
    assert main(["plan", "-m", "machine.toml", "--json", "true"]) == 2
    assert "unexpected extra argument(s) (true)" in capsys.readouterr().err
