"""A technician's first week (issue 38), replayed as a newcomer meets it.

38.1: after `ogacq demo`, then `ogacq sim --write-campaign` + `ogacq run`, the
README's `ogacq history "Orthoglide prototype"` lists both machines of that name
(the demo's simulator, serial SIM-1, and the machine file `sim` wrote, which now
carries a serial of its own), each label it prints is taken back, and rehearsals
raise no drift."""

from __future__ import annotations

import dataclasses
import os
import signal
import subprocess
import sys

import pytest

from ogacq.cli.app import main
from ogacq.history.drift import changes, controller_changes
from ogacq.io.machine_file import read_machine
from tests.cli.helpers import run_ogacq
from tests.history.test_drift import calibration
from tests.interrupts import sigint_as_at_a_terminal

PROTOTYPE = "Orthoglide prototype"


@pytest.mark.slow
def test_the_readme_history_command_after_demo_sim_and_run(tmp_path):
    history = tmp_path / "history.sqlite"
    demo = run_ogacq("demo", "--no-loop", "--speed", "50", "--out", tmp_path / "demo",
                     "--history", history)
    assert demo.returncode == 0, demo.stderr
    # it fits the terminal, its end as every line: a wider line is cut mid-word (issue
    # 38.6; "closing the loop ... in FOLDER/calibrate/" was one line of 125 characters)
    width = int(os.environ.get("COLUMNS", "80"))
    assert [line for line in demo.stdout.splitlines() if len(line) > width] == []

    campaign = tmp_path / "sim.toml"
    with sigint_as_at_a_terminal():  # the suite may run with SIGINT ignored
        sim = subprocess.Popen([sys.executable, "-m", "ogacq", "sim", "--speed", "50",
                                "--write-campaign", str(campaign)], stdout=subprocess.PIPE,
                               stderr=subprocess.PIPE, text=True, start_new_session=True,
                               env={**os.environ, "COLUMNS": "200"})
    try:
        said = sim.stderr.readline()  # the identity it gave the machine it wrote
        served = sim.stdout.readline()
        while "Ctrl-C" not in served:
            served = sim.stdout.readline()
        assert f"next, in another terminal: ogacq run {campaign}" in served
        serial = read_machine(tmp_path / "machine.toml").serial
        assert serial.startswith("SIM-") and serial in said
        # one cycle: this test is about what the history makes of it
        campaign.write_text(campaign.read_text().replace("cycles = 3", "cycles = 1"))
        ran = run_ogacq("run", campaign, "--history", history)
        assert ran.returncode == 0, ran.stderr
        # a rehearsal, on `ogacq sim`'s drives, not the built-in simulator (38.2)
        said = " ".join(ran.stdout.split())
        assert "SIMULATED a rehearsal on a simulator: not a calibration" in said, said
    finally:
        os.killpg(sim.pid, signal.SIGINT)
        sim.wait(60)

    shown = run_ogacq("history", PROTOTYPE, "--history", history)
    assert shown.returncode == 0, shown.stderr
    out = shown.stdout
    assert f"{PROTOTYPE} (serial SIM-1)" in out and f"{PROTOTYPE} (serial {serial})" in out
    assert "! drift" not in out and "outside ogacq" not in out

    listed = run_ogacq("history", "--history", history)
    assert f"{PROTOTYPE} (serial {serial})" in listed.stdout
    for typed in (f"{PROTOTYPE} (serial {serial})", serial):  # the label, the serial
        one = run_ogacq("history", typed, "--history", history, "--states")
        assert one.returncode == 0, one.stderr
    several = run_ogacq("history", PROTOTYPE, "--history", history, "--states")
    assert several.returncode == 2
    assert f"'{PROTOTYPE} (serial SIM-1)'" in several.stderr  # what to type instead


def test_rehearsals_are_kept_apart_from_the_machine_s_drift_checks():
    """A rehearsal between two calibrations of the machine is compared with neither
    (the machine's change is judged from one to the other), and a fresh simulator is
    no controller "changed outside ogacq"."""
    rehearsal = dataclasses.replace(calibration("R", "2026-02-01", 0.900, 0.006),
                                    simulated=True, offsets_in_force_mm={"x": 0.0})
    real = [dataclasses.replace(calibration("A", "2026-01-10", 0.300, 0.006),
                                offsets_in_force_mm={"x": 0.3}),
            rehearsal,
            dataclasses.replace(calibration("B", "2026-03-10", 0.330, 0.006),
                                offsets_in_force_mm={"x": 0.3})]
    assert [(d.from_record, d.to_record, d.flagged) for d in changes(real)] == [
        ("A", "B", True)]
    again = dataclasses.replace(rehearsal, record_id="R2", date="2026-02-02",
                                offsets_in_force_mm={"x": -0.9})
    assert controller_changes([rehearsal, again]) == []


def test_a_value_out_of_range_is_said_with_its_unit_and_metres_are_asked(tmp_path, capsys):
    """38.8: "squareness.xy must be -20..20, got 45" named no unit; a leg of 0.31025
    "mm" was refused as an impossible geometry without asking whether it was metres."""
    effects = tmp_path / "effects.toml"
    effects.write_text("[squareness]\nxy = 45\n")
    assert main(["demo", "--effects", str(effects), "--out", str(tmp_path / "d")]) == 2
    assert "squareness.xy must be -20..20 mrad, got 45 mrad" in capsys.readouterr().err
    machine = tmp_path / "machine.toml"
    machine.write_text("leg_length_mm = 0.31025\nrho_min_mm = -100\nrho_max_mm = 60\n"
                       "gauge_resolution_mm = 0.001\n")
    assert main(["refit", str(machine), "--machine", str(machine)]) == 2
    err = capsys.readouterr().err
    assert f"{machine}:1:" in err and "leg_length_mm = 0.31025 mm: metres? (310.25 mm" in err
