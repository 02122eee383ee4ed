"""``ogacq --verbose`` and ``--log-file``: info on the terminal when asked; every record,
with its time, in the file."""

from __future__ import annotations

import io
import logging
import re
from pathlib import Path

import pytest

from ogacq.cli.log_options import apply_log_options, global_options_first
from ogacq.cli.repeated_warnings import OneLineFormatter, RepeatCollapsingHandler
from ogacq.errors import InputError


@pytest.fixture
def terminal():
    root = logging.getLogger()
    saved_level, saved_handlers = root.level, list(root.handlers)
    stream = io.StringIO()
    handler = RepeatCollapsingHandler(stream)
    handler.setFormatter(OneLineFormatter())
    root.handlers = [handler]
    yield stream
    for extra in root.handlers:
        if extra is not handler:
            extra.close()
    root.handlers, root.level = saved_handlers, saved_level


def test_verbose_shows_info_and_the_file_gets_everything_timed(tmp_path, terminal):
    log = tmp_path / "ogacq.log"
    apply_log_options(verbose=True, log_file=log)
    logging.getLogger("ogacq_drivers.link").debug("frame %s", "0x01")
    logging.getLogger("ogacq.station").info("reconnected after 2 attempts")
    assert terminal.getvalue() == "ogacq: info: reconnected after 2 attempts\n"
    lines = log.read_text().splitlines()
    assert re.match(r"\d{4}-\d\d-\d\d \d\d:\d\d:\d\d,\d+ DEBUG ogacq_drivers.link: frame 0x01$",
                    lines[0])
    assert lines[1].endswith("INFO ogacq.station: reconnected after 2 attempts")


def test_without_verbose_the_terminal_keeps_to_warnings(terminal):
    apply_log_options(verbose=False, log_file=None)
    logging.getLogger("ogacq.station").info("reconnected")
    logging.getLogger("ogacq.station").warning("no reply")
    assert terminal.getvalue() == "ogacq: warning: no reply\n"


def test_an_unwritable_log_file_is_bad_input(terminal):
    with pytest.raises(InputError, match="cannot write the log file"):
        apply_log_options(verbose=False, log_file=Path("/proc/nope.log"))


@pytest.mark.parametrize("argv, expected", [
    (["run", "c.toml", "--log-file", "run.log"], ["--log-file", "run.log", "run", "c.toml"]),
    (["refit", "-v", "f.csv", "--log-file=a.log"], ["-v", "--log-file=a.log", "refit", "f.csv"]),
    (["--verbose", "demo"], ["--verbose", "demo"]),
    (["session", "show", "s.jsonl", "--", "-v"], ["session", "show", "s.jsonl", "--", "-v"]),
])
def test_global_options_are_taken_after_the_command_too(argv, expected):
    assert global_options_first(argv) == expected


def test_a_log_file_given_after_the_command_gets_the_log(tmp_path, terminal):
    from ogacq.cli.app import main

    log = tmp_path / "after.log"
    paper = Path(__file__).resolve().parents[2] / "ogacq" / "examples" / "paper"
    assert main(["refit", str(paper / "experiment2_12.csv"), "-m",
                 str(paper / "machine.toml"), "--json", "--log-file", str(log)]) == 0
    assert log.exists()
