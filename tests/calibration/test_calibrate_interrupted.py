"""``ogacq calibrate`` killed between a write to the machine and its audit's ``done``
record, then resumed, against a controller that outlives the process (an ``ogacq
sim`` process: its drives are not given back anything) and on the built-in
simulator. The validation is made worse on purpose (tests.calibration.interrupt
--flip), so the resume must restore: what the machine holds at the end is the state
before the calibration, and "RESTORED" is said only then.

On main these ended 'RESTORED to the previous state' with the new offsets still on
the controller (the write had no ``done`` record, so nothing was restored), or
refused the procedure's own half-written state as 'a later write-back or a manual
change'.
"""

from __future__ import annotations

import contextlib
import signal
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest

from ogacq.campaign.campaign_file import read_campaign
from ogacq.campaign.station import open_controller
from ogacq.session.records import CalibrateRecord, MapsRecord, OffsetsRecord
from ogacq.session.store import load_session
from ogacq.writeback.maps_table import maps_checksum, read_maps_table
from tests.writeback.conftest import sim_campaign, simulator

EFFECTS = "[squareness]\nxy = 0.5\n[encoder_scale]\nx = 400.0\n"


@contextlib.contextmanager
def served(folder: Path) -> Iterator[Path]:
    """``ogacq sim`` in its own process hiding EFFECTS, and a campaign file that talks
    to it, with a maps file."""
    with simulator(folder, "cia402", 3, EFFECTS) as info:
        yield sim_campaign(folder, info, name="station", maps_file="maps.json")


def interrupted(window: str, *args: str | Path) -> subprocess.CompletedProcess:
    """``ogacq ARGS`` stopped at ``window`` (tests.calibration.interrupt), worse on
    purpose."""
    return subprocess.run([sys.executable, "-m", "tests.calibration.interrupt", window,
                           "--flip", "--", *map(str, args)],
                          capture_output=True, text=True, timeout=300)


def killed_in(window: str, root: Path, *args: str | Path) -> Path:
    """``ogacq calibrate ARGS --out FOLDER`` killed at ``window``: FOLDER. A write the
    procedure refused (a reading far from its repeats, or a fit not within the noise at
    the 1 % level: a correct campaign's once in a hundred each) never reaches the
    window: that refusal alone gets another campaign."""
    for attempt in ("cal", "cal-again", "cal-third"):
        folder = root / attempt
        killed = interrupted(window, "calibrate", *args, "--out", folder)
        if not (killed.returncode == 4 and (folder / "procedure.jsonl").is_file()
                and "refused" in steps(folder)):
            break
    assert killed.returncode == -signal.SIGKILL, killed.stderr[-2000:]
    return folder


def held(campaign: Path) -> dict[str, float]:
    with open_controller(read_campaign(campaign).controller) as controller:
        return {a: round(v, 4) for a, v in controller.read_offsets().items()}


def steps(folder: Path) -> dict[str, dict]:
    return {r.step: r.details for r in
            load_session(folder / "procedure.jsonl").of_type(CalibrateRecord)}


@pytest.mark.parametrize("window", ["offsets-half", "offsets-done"])
def test_killed_in_a_write_to_an_external_controller_resumes_to_the_state_before(
        tmp_path, window):
    with served(tmp_path) as campaign:
        before = held(campaign)
        folder = killed_in(window, tmp_path, campaign, "--yes", "--no-separate",
                           "--history", "none")
        assert held(campaign) != before  # the kill left new values on the controller
        resumed = interrupted("none", "calibrate", "--resume", folder, "--yes",
                              "--history", "none")
        assert resumed.returncode == 4, resumed.stderr[-2000:]
        assert "RESTORED to the previous state" in resumed.stderr
        assert held(campaign) == before  # what was said is what the controller holds
        log = steps(folder)
        assert log["finished"]["outcome"] == "restored" and log["restored"]["offsets"]
        audit = load_session(folder / "calibration.jsonl").of_type(OffsetsRecord)
        assert [r.details["action"] for r in audit if r.stage == "done"][-1] == "restore"
        assert "a later write-back or a manual change" not in resumed.stderr


def test_killed_after_the_maps_file_was_replaced_on_the_simulator(tmp_path):
    """The maps file outlives the process: replaced, killed before ``done``, resumed:
    the map the validation judged worse is not left in force."""
    effects = tmp_path / "effects.toml"
    effects.write_text(EFFECTS)
    folder = killed_in("maps-done", tmp_path, "--simulator", "--effects", effects, "--seed",
                       "3", "--speed", "50", "--yes", "--no-separate", "--history", "none")
    assert read_maps_table(folder / "maps.json").maps  # the sign-turned map in force
    resumed = interrupted("none", "calibrate", "--resume", folder, "--yes", "--history", "none")
    assert resumed.returncode == 4, resumed.stderr[-2000:]
    assert "RESTORED to the previous state" in resumed.stderr
    assert read_maps_table(folder / "maps.json").checksum == maps_checksum({})
    maps_done = [(r.details["action"], "found" in r.details) for r in
                 load_session(folder / "calibration.jsonl").of_type(MapsRecord)
                 if r.stage == "done"]
    # the write killed before its record, found in force by the resume, then restored
    assert maps_done == [("write", True), ("restore", False)]
    assert steps(folder)["restored"]["maps"]
