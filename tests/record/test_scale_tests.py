"""The record's ``axis_scales`` instrument of a positioning test's session: as the
session recorded it, or (a session from before it recorded its instrument) what its
station opened the scale with."""

from __future__ import annotations

import datetime as dt

from ogacq.record.scale_tests import _instrument
from ogacq.session.store import SessionWriter, load_session

OPENED = {"axis_scales": {"x": {"serial": "AT-1", "resolution_mm": 0.001}}}


def _session(tmp_path, header):
    path = tmp_path / "positioning-before-x.jsonl"
    SessionWriter.create(path, {"kind": "positioning", "station": OPENED, **header}).close()
    return load_session(path)


def test_the_scale_as_its_test_recorded_it_with_its_certificate_status(tmp_path):
    scale = {"gauge": "scale_x", "make": "Mitutoyo", "serial": "AT-1", "certificate": "C-9",
             "due": "2026-01-31", "uncertainty_mm": 0.002, "uncertainty_k": 2.0,
             "resolution_mm": 0.001}
    on = dt.date(2026, 2, 1).isoformat()
    found = _instrument(_session(tmp_path, {"instruments": [scale], "date": on}), "x")
    assert found["certificate"] == "C-9" and found["make"] == "Mitutoyo"
    assert found["expired"] is True  # the day after its due date


def test_a_session_before_its_instrument_was_recorded_gives_what_its_station_opened(
        tmp_path):
    found = _instrument(_session(tmp_path, {}), "x")
    assert (found["gauge"], found["serial"], found["resolution_mm"]) == \
        ("scale_x", "AT-1", 0.001)
    assert found["certificate"] is None and found["expired"] is None
