"""`ogacq ... | head`: when the reader of standard output leaves, the command ends
quietly with 141 (128 + SIGPIPE, what a shell reports of `git log | head`), on both
parsers (the fast path's and typer's, where click and rich each end the command
their own way), and a device's broken pipe is still an error."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from ogacq.cli.say import SIGPIPE_EXIT

PAPER = Path(__file__).resolve().parents[2] / "ogacq" / "examples" / "paper"
TABLE, MACHINE = str(PAPER / "experiment1_6.csv"), str(PAPER / "machine.toml")


def into_a_pipe_nobody_reads(*args: str) -> subprocess.CompletedProcess[str]:
    """``ogacq ARGS`` writing into a pipe whose reading end is closed before the
    command starts: its first write to standard output finds no reader, whatever the
    pipe's buffer would have held."""
    read_end, write_end = os.pipe()
    os.close(read_end)
    try:
        return subprocess.run([sys.executable, "-m", "ogacq", *args], stdout=write_end,
                              stderr=subprocess.PIPE, text=True, timeout=300, check=False)
    finally:
        os.close(write_end)


@pytest.mark.parametrize("args", [
    ("refit", TABLE, "-m", MACHINE),  # the fast path, plain text
    ("diagnose", TABLE, "-m", MACHINE, "--json"),  # the fast path, JSON
    ("refit", TABLE, "-m", MACHINE, "--params", "offsets"),  # typer's, plain text
    ("plan", "--machine", MACHINE),  # typer's, rich's tables
    ("--help",),  # click's help
])
def test_a_reader_that_left_ends_the_command_quietly(args):
    ran = into_a_pipe_nobody_reads(*args)
    assert (ran.returncode, ran.stderr) == (SIGPIPE_EXIT, "")


def test_a_command_whose_output_is_read_is_unchanged():
    ran = subprocess.run([sys.executable, "-m", "ogacq", "refit", TABLE, "-m", MACHINE],
                         capture_output=True, text=True, timeout=300, check=False)
    assert ran.returncode == 0 and "joint" in ran.stdout


def test_a_broken_pipe_elsewhere_is_an_error_with_its_line(tmp_path, monkeypatch, capsys):
    # standard output is read (pytest's capture): the broken pipe is a device's
    from ogacq.cli import app

    def broken(argv: list[str]) -> int:
        raise BrokenPipeError(32, "Broken pipe")

    monkeypatch.setattr(app, "_run", broken)
    assert app.main(["refit", TABLE]) == 3
    assert capsys.readouterr().err == "ogacq: error: Broken pipe\n"
