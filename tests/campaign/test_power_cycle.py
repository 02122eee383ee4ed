"""A drive power-cycled mid-campaign, against the independent emulator (modbus_tk,
written from CiA 402, not ogacq's simulator; see tests/campaign/emulated_station.py).

The drives' counters restart at arbitrary values (beyond the soft limits) and
nothing in the drive says whether it is homed: the emulator's request log must
show no target written between the power cycle and the end of the new homing.
Then either the campaign re-homes, checks the posture of its last reading, and
completes with readings equal to an uninterrupted campaign's within the noise;
or, with re-homing unattended not allowed, it stops with exit 3 and resumes."""

from __future__ import annotations

import io

import pytest

from ogacq.campaign.campaign_file import read_campaign
from ogacq.cli.app import main
from ogacq.session.records import EndRecord, ReconnectRecord, ReferenceRecord
from ogacq.session.store import load_session
from tests.campaign.emulated_station import NOISE_MM, emulated_station, event_index, target_writes
from tests.writeback.conftest import ogacq_here

pytestmark = pytest.mark.filterwarnings("ignore:isSet:DeprecationWarning")

# Two readings of one posture differ by the noise of each and the display step:
# five standard deviations of the difference, and the step.
SAME_WITHIN_MM = 5 * NOISE_MM * 2 ** 0.5 + 0.001
CYCLED_AFTER = 10  # readings on file when the drives are switched off and on


@pytest.fixture(scope="module")
def rig(tmp_path_factory):
    with emulated_station() as station:
        yield station, tmp_path_factory.mktemp("power-cycle")


@pytest.fixture(scope="module")
def uninterrupted(rig):
    station, folder = rig
    path = station.campaign(folder, "uninterrupted")
    with pytest.MonkeyPatch.context() as monkeypatch:
        monkeypatch.setattr("sys.stdin", io.StringIO(""))
        assert main(["run", str(path), "--json"]) == 0
    return readings(path)


def readings(path) -> dict[tuple[str, str], float]:
    session = load_session(read_campaign(path).session)
    out = {(r.step, r.gauge.key): r.reading_mm for r in session.readings}
    assert len(out) == len(session.readings), "a reading was taken twice"
    return out


def assert_same_readings(got: dict, expected: dict) -> None:
    assert got.keys() == expected.keys()
    worst = max(abs(got[k] - expected[k]) for k in got)
    assert worst <= SAME_WITHIN_MM, f"readings differ by up to {worst:.4f} mm"


def no_setpoint_before_homed(station, before: dict[str, int]) -> None:
    """On each drive: the power cycle, then homing done, and no target written between."""
    for axis, drive in station.drives.items():
        cycled = event_index(drive, "power cycle", before[axis])
        assert cycled is not None, drive.events
        homed = event_index(drive, "homed", cycled)
        assert homed is not None, drive.events
        assert target_writes(drive, cycled, homed) == 0, axis
        assert target_writes(drive, homed) > 0  # and the campaign went on after


def test_a_power_cycle_is_rehomed_checked_and_the_campaign_completes(
        rig, uninterrupted, capsys, monkeypatch):
    station, folder = rig
    path = station.campaign(folder, "cycled")
    before = station.requests()
    watcher = station.power_cycle_when(read_campaign(path).session, CYCLED_AFTER)
    ran = ogacq_here(capsys, monkeypatch, "run", path, "--json")
    watcher.join(5)
    assert ran.returncode == 0, ran.stderr
    no_setpoint_before_homed(station, before)
    session = load_session(read_campaign(path).session)
    assert session.finished
    assert_same_readings(readings(path), uninterrupted)
    (back,) = session.of_type(ReconnectRecord)
    assert back.connected
    events = [r.event for r in session.of_type(ReferenceRecord)]
    assert events == ["lost", "rehomed", "checked"]
    lost = session.of_type(ReferenceRecord)[0]
    assert lost.cause == "reconnect"
    assert "outside the soft limits" in " ".join(lost.axes["x"]["reasons"])  # 67.77 mm
    checked = session.of_type(ReferenceRecord)[-1]
    assert max(abs(d) for d in checked.differences_mm.values()) <= checked.tolerance_mm


def test_no_unattended_homing_stops_with_exit_3_and_resumes(
        rig, uninterrupted, capsys, monkeypatch):
    station, folder = rig
    path = station.campaign(folder, "cycled-stop", rehome=False)
    before = station.requests()
    watcher = station.power_cycle_when(read_campaign(path).session, CYCLED_AFTER)
    ran = ogacq_here(capsys, monkeypatch, "run", path)
    watcher.join(5)
    assert ran.returncode == 3
    stopped = [line for line in ran.stderr.splitlines() if "rehome_after_loss" in line]
    assert len(stopped) == 1 and "Traceback" not in ran.stderr
    cycled = {a: event_index(d, "power cycle", before[a]) for a, d in station.drives.items()}
    for axis, drive in station.drives.items():
        assert target_writes(drive, cycled[axis]) == 0
        assert event_index(drive, "homed", cycled[axis]) is None
    session = load_session(read_campaign(path).session)
    end = session.of_type(EndRecord)[-1]
    assert end.status == "stopped" and "lost its position reference" in end.reason
    assert [r.event for r in session.of_type(ReferenceRecord)] == ["lost"]
    taken = len(session.readings)
    assert CYCLED_AFTER <= taken < 24

    resumed = ogacq_here(capsys, monkeypatch, "resume", str(session.path), "--json")
    assert resumed.returncode == 0, resumed.stderr
    no_setpoint_before_homed(station, cycled)
    session = load_session(session.path)
    assert session.finished
    assert session.of_type(ReferenceRecord)[-1].event == "checked"
    assert_same_readings(readings(path), uninterrupted)


def test_a_reference_that_moved_is_caught_at_the_check_posture(rig, capsys, monkeypatch):
    """A home offset written but not saved: the power cycle brings back the saved one,
    the new homing puts the joint zero 0.5 mm elsewhere, and the check posture says
    the readings taken before are not to be trusted (exit 3)."""
    station, folder = rig
    for drive in station.drives.values():
        drive.put(0x607C, 50)  # counts, in RAM only: saved_home_offset stays 0
    path = station.campaign(folder, "unsaved-offset")
    watcher = station.power_cycle_when(read_campaign(path).session, CYCLED_AFTER)
    ran = ogacq_here(capsys, monkeypatch, "run", path)
    watcher.join(5)
    assert ran.returncode == 3
    assert "readings taken before are not to be trusted" in ran.stderr
    session = load_session(read_campaign(path).session)
    events = session.of_type(ReferenceRecord)
    assert [r.event for r in events] == ["lost", "rehomed", "check_failed"]
    assert max(abs(d) for d in events[-1].differences_mm.values()) > 0.1
    assert session.of_type(EndRecord)[-1].status == "stopped"
