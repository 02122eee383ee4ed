"""A campaign records who ran it, on which machine, when, with which instruments and
at what temperature; a gauge past its due date is refused before anything moves,
and overriding it is recorded. Against the built-in simulator, through the real
drivers."""

from __future__ import annotations

import datetime

import numpy as np
import pytest

from ogacq_drivers.sim.clock import SimClock
from ogacq_drivers.sim.motion import MotionModel
from ogacq.campaign.campaign_file import read_campaign
from ogacq.campaign.run import run_campaign
from ogacq.campaign.station import start_simulator
from ogacq.errors import Refused
from ogacq.model.machine import MachineSpec
from ogacq.model.parameters import AXES, PARAM_INDEX
from ogacq.record.context import calibration_context
from ogacq.session.records import EnvironmentRecord, OverrideRecord
from ogacq.session.store import load_session
from ogacq.sim.machine import SimMachine
from ogacq.sim.truth import random_truth
from tests.cli.helpers import run_ogacq

MACHINE = """name = "OG-1 cell 3"
serial = "OG-2026-0017"
leg_length_mm = 310.25
rho_min_mm = -100.0
rho_max_mm = 60.0
gauge_resolution_mm = 0.001
"""
EXPIRED_Y_X = """[[gauges]]
gauge = "y_x"
make = "Mitutoyo"
serial = "12345678"
certificate = "DKD-K-12345 2025-0112"
calibrated = 2025-01-12
due = 2026-01-05
uncertainty_mm = 0.0015
uncertainty_k = 2.0
"""


def write(folder, environment: str, extra: str = "") -> object:
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "machine.toml").write_text(MACHINE)
    path = folder / "campaign.toml"
    path.write_text('machine = "machine.toml"\noperator = "J. Martin"\n'
                    'session = "session.jsonl"\n' + extra
                    + "[simulator]\nseed = 3\nspeed = 50\ndate = 2026-01-10T09:00:00\n"
                      "ambient_c = 23.5\n"
                    + "[protocol]\ncycles = 1\nsettle_s = 0.5\n" + environment + EXPIRED_Y_X)
    return path


def test_an_expired_gauge_is_refused_before_anything_moves(tmp_path):
    campaign = read_campaign(write(tmp_path / "c", ""))
    with start_simulator(campaign.machine, campaign.simulator) as stack:
        with pytest.raises(Refused) as refused:
            run_campaign(campaign, simulator=stack)
        for axis in AXES:  # nothing enabled, homed or moved
            snap = stack.motion.snapshot(axis)
            assert not snap.servo_on and not snap.homed and snap.raw_mm == 0.0
    message = str(refused.value)
    assert "y_x (serial 12345678, due 2026-01-05)" in message and "2026-01-10" in message
    assert not campaign.session.exists()  # no session, so no reading
    proc = run_ogacq("run", campaign.path)  # the command says it in one line, exit 4
    assert proc.returncode == 4 and len(proc.stderr.strip().splitlines()) == 1
    assert "--override-expired REASON" in proc.stderr and not campaign.session.exists()
    blank = run_ogacq("run", campaign.path, "--override-expired", " ")
    assert blank.returncode == 2 and "give the reason" in blank.stderr


def test_override_and_sensor_temperatures_are_recorded(tmp_path):
    path = write(tmp_path / "c", '[environment]\nsensor = "controller"\n')
    proc = run_ogacq("run", path, "--override-expired", "checked on gauge blocks today",
                     "--json")
    assert proc.returncode == 0, proc.stderr
    session = load_session(tmp_path / "c" / "session.jsonl")
    assert session.finished
    (override,) = session.of_type(OverrideRecord)
    assert (override.what, override.subject, override.due, override.reason,
            override.operator) == ("expired-gauge", "y_x 12345678", "2026-01-05",
                                   "checked on gauge blocks today", "J. Martin")
    # read from the simulated controller's temperature registers at the start and end
    assert [(r.stage, r.ambient_c, r.machine_c, r.source)
            for r in session.of_type(EnvironmentRecord)] == [
        ("start", 23.5, 23.5, "sensor"), ("end", 23.5, 23.5, "sensor")]
    assert session.header.date == "2026-01-10T09:00:00"
    assert session.header.simulator["simulated_date"] is True
    context = calibration_context(session)
    assert (context.machine_name, context.machine_serial, context.operator) == (
        "OG-1 cell 3", "OG-2026-0017", "J. Martin")
    y_x = context.instrument("y_x")
    assert y_x.serial == "12345678" and y_x.standard_uncertainty_mm == 0.00075
    assert context.expired(y_x) is True
    assert context.instrument("z_x").serial == "sim-z_x"  # the simulator's, no certificate
    assert context.environment.temperature_c == 23.5
    assert [o.reason for o in context.overrides] == ["checked on gauge blocks today"]
    shown = " ".join(run_ogacq("session", "show", session.path).stdout.split())
    assert "operator J. Martin; date 2026-01-10 09:00:00 (rehearsed" in shown
    assert "gauge y_x (serial 12345678): certificate DKD-K-12345 2025-0112, due 2026-01-05 " \
           "(EXPIRED)" in shown
    assert "temperature: start 23.5 °C ambient, 23.5 °C machine (sensor)" in shown
    assert "override (expired-gauge) y_x 12345678: checked on gauge blocks today" in shown


def test_typed_temperatures_and_the_campaign_files_override(tmp_path):
    path = write(tmp_path / "c", "[environment]\nambient_c = 20.4\nmachine_c = 21.0\n",
                 extra='[override]\nexpired_gauges = "recalibration booked"\n')
    assert run_ogacq("run", path, "--json").returncode == 0
    session = load_session(tmp_path / "c" / "session.jsonl")
    # typed once in the file: the start only (the end was not measured)
    assert [(r.stage, r.ambient_c, r.machine_c, r.source)
            for r in session.of_type(EnvironmentRecord)] == [("start", 20.4, 21.0, "typed")]
    assert [r.reason for r in session.of_type(OverrideRecord)] == ["recalibration booked"]


def test_the_simulated_legs_expand_with_the_temperature():
    machine = MachineSpec(310.25, -100.0, 60.0, gauge_resolution_mm=0.001,
                          leg_expansion_ppm_per_k=23.0)  # aluminium legs
    base = random_truth(3)
    warm = base.at_temperature(machine, 30.0)
    for axis in AXES:
        assert warm.theta[PARAM_INDEX[f"leg_length.{axis}"]] == pytest.approx(
            23e-6 * 310.25 * 10)
    assert np.array_equal(base.at_temperature(machine, 20.0).theta, base.theta)

    def max_posture_x_leg(truth) -> float:
        clock = SimClock(1.0)
        sim = SimMachine(machine, truth, MotionModel(clock), clock)
        q = np.array([60.0, 0.0, 0.0])
        return sim.coordinates_mm(q, np.ones(3), 0.0)[(1, 0)] - \
            sim.coordinates_mm(np.zeros(3), np.ones(3), 0.0)[(1, 0)]

    # the gauge along y on the x leg sees the longer legs between Zero and Max
    assert abs(max_posture_x_leg(warm) - max_posture_x_leg(base)) > 1e-4


def test_rehearsed_date_defaults_to_now(tmp_path):
    (tmp_path / "machine.toml").write_text(MACHINE)
    (tmp_path / "c.toml").write_text('machine = "machine.toml"\n[simulator]\nseed = 1\n')
    campaign = read_campaign(tmp_path / "c.toml")
    now = datetime.datetime.now()
    assert abs((campaign.campaign_date() - now).total_seconds()) < 60
