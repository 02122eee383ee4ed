"""``calibrate --simulator --machine FILE`` rehearses on that machine file: its legs,
travel and gauges' display step, under the rehearsal's serial (the history keeps the
rehearsal apart from the machine). Before, the simulator rehearsed only the papers'
1 µm prototype: a 10 µm dial's calibration could not be rehearsed at all. The procedure
is replaced by one that records the setup it was given (the campaign's run is tested
elsewhere); a resume reads the machine back from the folder."""

from __future__ import annotations

from pathlib import Path

from ogacq.io.machine_file import read_machine
from tests.writeback.conftest import ogacq_here

EXAMPLE = Path(__file__).parents[2] / "ogacq" / "examples" / "machine.toml"


def test_a_rehearsal_runs_on_the_machine_file_given(tmp_path, capsys, monkeypatch, started):
    given = read_machine(EXAMPLE)
    assert given.gauge_resolution_mm == 0.01
    folder = tmp_path / "run"
    ran = ogacq_here(capsys, monkeypatch, "calibrate", "--simulator", "--machine", EXAMPLE,
                     "--seed", 5, "--out", folder, "--yes", "--history", "none")
    assert ran.returncode == 4 and "stopped by the test" in ran.stderr, ran.stderr
    ((setup, _),) = started
    assert setup.machine.gauge_resolution_mm == 0.01
    assert setup.machine.leg_length_mm == given.leg_length_mm
    assert setup.machine.serial == "SIM-5" != given.serial
    assert read_machine(folder / "machine.toml") == setup.machine  # what a resume reads


def test_a_machine_file_without_the_simulator_is_refused(tmp_path, capsys, monkeypatch):
    ran = ogacq_here(capsys, monkeypatch, "calibrate", tmp_path / "campaign.toml",
                     "--machine", EXAMPLE, "--yes", "--history", "none")
    assert ran.returncode == 2 and "--machine" in ran.stderr, ran.stderr
