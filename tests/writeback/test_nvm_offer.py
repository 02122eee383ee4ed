"""The non-volatile save, offered where the drive has one, against the independent
emulator (modbus_tk, tests/emulators/drives.py: a CiA 402 drive whose store
parameters 1010h keeps the home offset through a power cycle). `offsets write`
asks whether to save; the session's record says whether the values written
survive a power cycle, and switching the emulated drives off and on shows that it
says true."""

from __future__ import annotations

import pytest

from ogacq.model.parameters import AXES
from ogacq.record.document import build_record
from ogacq.session.records import OffsetsRecord
from ogacq.session.store import load_session
from tests.emulators.drives import Cia402Drive, EmulatorServer
from tests.writeback.conftest import (
    controller_offsets,
    emulated_campaign,
    ogacq_here,
    synthetic_session,
)

pytestmark = pytest.mark.filterwarnings("ignore:isSet:DeprecationWarning")

OFFSETS = {"x": 0.8, "y": -0.6, "z": 1.2}


@pytest.fixture
def emulated(tmp_path):
    server = EmulatorServer("tcp")
    drives = {a: server.add(u, Cia402Drive) for a, u in {"x": 1, "y": 2, "z": 3}.items()}
    campaign = emulated_campaign(tmp_path, server.start())
    try:
        yield drives, campaign
    finally:
        server.stop()


@pytest.mark.parametrize("save", [True, False])
def test_the_save_is_offered_and_the_record_says_what_a_power_cycle_does(
        tmp_path, capsys, monkeypatch, emulated, save):
    drives, campaign = emulated
    session = synthetic_session(tmp_path / "s.jsonl", campaign, offsets_mm=OFFSETS)
    ran = ogacq_here(capsys, monkeypatch, "offsets", "write", session, "-c", campaign,
                     "--max-change-mm", "2", stdin="y\n" + ("y\n" if save else "n\n"))
    assert ran.returncode == 0, ran.stdout + ran.stderr
    assert "Save them to the drive's non-volatile memory too?" in ran.stdout
    written = controller_offsets(campaign)
    assert written != dict.fromkeys(AXES, 0.0)
    done = load_session(session).of_type(OffsetsRecord)[-1]
    assert done.details["nvm_saved"] is save
    assert done.details["survives_power_cycle"] is save
    if not save:
        assert "NOT saved to non-volatile memory" in ran.stdout
    assert all(d.saves == (1 if save else 0) for d in drives.values())
    # the calibration record says it too
    said = build_record(load_session(session))["writeback"][-1]["details"]
    assert ("survives a power cycle" if save else "a power cycle brings back") in said

    for drive in drives.values():
        drive.power_cycle()
    after = controller_offsets(campaign)
    expected = written if save else dict.fromkeys(AXES, 0.0)
    assert after == pytest.approx(expected, abs=0.006)


def test_unattended_writes_do_not_save_and_say_so(tmp_path, capsys, monkeypatch, emulated):
    drives, campaign = emulated
    session = synthetic_session(tmp_path / "s.jsonl", campaign, offsets_mm=OFFSETS)
    ran = ogacq_here(capsys, monkeypatch, "offsets", "write", session, "-c", campaign,
                     "--max-change-mm", "2", "--yes")
    assert ran.returncode == 0, ran.stdout + ran.stderr
    assert "non-volatile memory too?" not in ran.stdout
    assert "NOT saved to non-volatile memory" in ran.stdout
    assert all(d.saves == 0 for d in drives.values())
    assert load_session(session).of_type(OffsetsRecord)[-1].details[
        "survives_power_cycle"] is False
