"""``offsets restore`` after a write that failed at its own check: against the
independent emulator (tests/emulators/drives.py) whose drives put the home offset at
the home point with the sign opposite the cia402 profile's. The write's pre-flight
homes with offset 0 (no sign to see), the write is read back, and its homing shows the
new offsets turned: failed, the drive holding them. The restore's pre-flight homing
then found that same sign and refused, leaving the drive holding the failed write's
offsets until a power cycle (issue 36.7); it writes the old values back, checked by
read-back and at its own homing."""

from __future__ import annotations

import pytest

from ogacq.model.parameters import AXES
from ogacq.session.records import OffsetsRecord
from ogacq.session.store import load_session
from tests.emulators.drives import Cia402Drive, EmulatorServer
from tests.writeback.conftest import (
    controller_offsets,
    emulated_campaign,
    ogacq_here,
    synthetic_session,
)
from tests.writeback.test_nvm_offer import OFFSETS

pytestmark = pytest.mark.filterwarnings("ignore:isSet:DeprecationWarning")


@pytest.fixture
def turned(tmp_path):
    """Three drives whose home offset acts with the sign opposite the profile's."""
    server = EmulatorServer("tcp")
    for unit in (1, 2, 3):
        server.add(unit, Cia402Drive, home_sign=+1)
    campaign = emulated_campaign(tmp_path, server.start())
    try:
        yield campaign
    finally:
        server.stop()


def test_a_write_failed_at_its_homing_is_restored(tmp_path, capsys, monkeypatch, turned):
    campaign = turned
    session = synthetic_session(tmp_path / "s.jsonl", campaign, offsets_mm=OFFSETS)
    write = ogacq_here(capsys, monkeypatch, "offsets", "write", session, "-c", campaign,
                       "--yes", "--history", "none")
    assert write.returncode == 3, write.stdout + write.stderr
    assert controller_offsets(campaign) != dict.fromkeys(AXES, 0.0)  # left by the failure
    back = ogacq_here(capsys, monkeypatch, "offsets", "restore", session, "-c", campaign,
                      "--yes", "--history", "none")
    assert back.returncode == 0, back.stdout + back.stderr
    assert controller_offsets(campaign) == pytest.approx(dict.fromkeys(AXES, 0.0), abs=1e-9)
    done = [r.details["action"] for r in load_session(session).of_type(OffsetsRecord)
            if r.stage == "done"]
    assert done == ["restore"]
