"""Fixtures of the calibration procedure's tests."""

from __future__ import annotations

import pytest

from ogacq.calibration import procedure
from ogacq.errors import Refused


@pytest.fixture
def started(monkeypatch):
    """The setups ``ogacq calibrate`` started its procedure with, each stopped at once
    (the folder's and the options' hand-over is tested, not a calibration)."""
    setups = []

    def stop_at_once(setup, ui, *, resume, history=None):
        setups.append((setup, resume))
        raise Refused("stopped by the test before any campaign")

    monkeypatch.setattr(procedure, "calibrate", stop_at_once)
    return setups
