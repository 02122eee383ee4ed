"""A gauge sending garbage is read again and again while a stable value is awaited,
each frame discarded with a warning: the command line prints the first and counts
the rest, in one line, instead of thousands."""

from __future__ import annotations

import io
import logging

import pytest

from ogacq_drivers.errors import DriverError
from ogacq_drivers.indicators.base import read_stable
from ogacq.campaign.campaign_file import read_campaign
from ogacq.campaign.station import open_station
from ogacq.cli.repeated_warnings import RepeatCollapsingHandler
from tests.campaign.conftest import write_campaign


@pytest.fixture
def printed():
    """What the command line's handler prints of the drivers' warnings."""
    stream = io.StringIO()
    handler = RepeatCollapsingHandler(stream)
    handler.setFormatter(logging.Formatter("ogacq: warning: %(message)s"))
    drivers_log = logging.getLogger("ogacq_drivers")
    drivers_log.addHandler(handler)
    try:
        yield stream, handler
    finally:
        drivers_log.removeHandler(handler)


def test_a_gauge_sending_garbage_prints_one_warning_and_a_count(tmp_path, printed):
    stream, handler = printed
    campaign = read_campaign(write_campaign(tmp_path, seed=1))
    with open_station(campaign) as station:
        station.simulator.gauges["z_x"].set_fault("garbled")  # every frame, until cleared
        with pytest.raises(DriverError):
            read_stable(station.indicators["z_x"], 2, 0.003, timeout_s=0.5)
    handler.flush()
    lines = stream.getvalue().splitlines()
    assert len(lines) == 2, lines
    assert lines[0].startswith("ogacq: warning: gauge z_x") and "discarding a reading" in lines[0]
    repeats = int(lines[1].split("repeated ")[1].split()[0])
    assert lines[1] == f"ogacq: (the warning above repeated {repeats} more times)"
    assert repeats >= 10  # a frame every few milliseconds for half a second


def test_a_different_warning_says_the_count_first_then_prints(printed):
    stream, handler = printed
    log = logging.getLogger("ogacq_drivers.test")
    for k in range(3):
        log.warning("frame %d garbled", k)
    log.warning("gauge unplugged")
    log.warning("gauge unplugged")
    handler.flush()
    assert stream.getvalue().splitlines() == [
        "ogacq: warning: frame 0 garbled",
        "ogacq: (the warning above repeated 2 more times)",
        "ogacq: warning: gauge unplugged",
        "ogacq: (the warning above repeated 1 more time)",
    ]
