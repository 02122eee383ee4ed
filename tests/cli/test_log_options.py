"""``ogacq --verbose`` and ``--log-file``: info on the terminal when asked; every record,
with its time, in the file."""

from __future__ import annotations

import io
import logging
import re
from pathlib import Path

import pytest

from ogacq.cli.log_options import apply_log_options
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
