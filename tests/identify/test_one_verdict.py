"""One verdict: the diagnosis, the write-back gate, the report and the CLI state the
same one for any session; the test's false-alarm rate is what it says on a slice of
the calibration grid (``bench/verdict_calibration.py`` runs all of it)."""

from __future__ import annotations

import numpy as np
import pytest

from ogacq.diagnose.diagnosis import diagnose
from ogacq.identify.consistency import LEVEL, fit_verdict
from ogacq.identify.fit import fit
from ogacq.identify.verdict_calibration import Cell, alarm_rate, seeds_of, simulated_observations
from ogacq.io.tables import write_readings
from ogacq.model.parameters import PARAM_SETS
from ogacq.record.calibration_record import CalibrationRecord
from ogacq.record.document import build_record
from ogacq.report.page import recorded_verdict
from ogacq.session.convert import import_readings, session_observations
from ogacq.session.identification import identify_session
from ogacq.session.store import load_session
from ogacq.writeback.evidence import evidence_from_session
from tests.cli.helpers import run_ogacq

DIAL = Cell(0.01, 0.001, "repeats", "papers", "prototype")  # the papers' 10 um dials
FINE = Cell(0.001, 0.002, "declared", "both-sides", "prototype")


def disturbed(cell: Cell, seed: int, shift_mm: float):
    """One gauge at one posture moved by ``shift_mm`` on every cycle (a knocked stand)."""
    obs = simulated_observations(cell, seed)
    lay = obs.layout
    at = (lay.gauge_axis == 2) & (lay.leg == 1) & (lay.tcp_mm[:, 1] < -99.0)
    obs.values = obs.values + np.where(at, shift_mm, 0.0)
    return obs


CASES = [
    ("control, 10 um dials", lambda: simulated_observations(DIAL, 5)),
    ("control, 1 um display", lambda: simulated_observations(FINE, 1)),
    ("squareness", lambda: simulated_observations(FINE, 2, {"squareness.xy": 0.5})),
    ("axis offset on dials", lambda: simulated_observations(DIAL, 3, {"axis_offset.xz": 0.05})),
    ("one cell 2.5 um", lambda: disturbed(FINE, 4, 0.0025)),
    ("one cell 25 um on dials", lambda: disturbed(DIAL, 4, 0.025)),
]


@pytest.mark.parametrize(("label", "make"), CASES, ids=[c[0] for c in CASES])
def test_every_consumer_states_the_same_verdict(tmp_path, label, make):
    obs = make()
    csv = tmp_path / "r.csv"
    write_readings(csv, obs.layout, obs.values)
    session = load_session(import_readings(csv, obs.machine, tmp_path / "s.jsonl"))

    diagnosis = diagnose(session_observations(session), separate=False).base
    gate = evidence_from_session(session).verdict
    # the report states its record's verdict
    report_state, report_text = recorded_verdict(CalibrationRecord.from_json(
        build_record(session)))
    wizard = fit_verdict(identify_session(session))  # what the wizard and refit print
    assert gate.state == diagnosis.state == report_state == wizard.state, label
    assert gate.p_value == pytest.approx(diagnosis.p_value, rel=1e-6, abs=1e-12)
    assert report_text == gate.describe()
    assert f"judged at the {LEVEL:g} level" in gate.describe()


def test_the_command_line_states_the_same_verdict(tmp_path):
    obs = disturbed(FINE, 4, 0.0025)
    write_readings(tmp_path / "r.csv", obs.layout, obs.values)
    run_ogacq("session", "import", tmp_path / "r.csv", tmp_path / "s.jsonl", "--machine",
              _machine_file(tmp_path, obs.machine))
    verdict = fit_verdict(fit(obs, PARAM_SETS["offsets"]))
    refit = run_ogacq("refit", tmp_path / "s.jsonl")
    diagnosed = run_ogacq("diagnose", tmp_path / "s.jsonl")
    headline = verdict.headline()
    assert headline in " ".join(refit.stdout.split())
    assert f"joint offsets only: {headline}" in " ".join(diagnosed.stdout.split())


def _machine_file(folder, machine):
    path = folder / "m.toml"
    lines = [f"leg_length_mm = {machine.leg_length_mm}", f"rho_min_mm = {machine.rho_min_mm}",
             f"rho_max_mm = {machine.rho_max_mm}",
             f"gauge_resolution_mm = {machine.gauge_resolution_mm}"]
    if machine.gauge_repeatability_mm is not None:
        lines.append(f"gauge_repeatability_mm = {machine.gauge_repeatability_mm}")
    path.write_text("\n".join(lines) + "\n")
    return path


@pytest.mark.parametrize("cell", [
    DIAL, FINE,
    Cell(0.01, 0.002, "declared", "papers", "large"),
    Cell(0.001, 0.0003, "repeats", "both-sides", "large"),
], ids=lambda c: c.label().replace("  ", " ").strip())
def test_false_alarms_on_a_slice_of_the_calibration_grid(cell):
    rate = alarm_rate(cell, seeds_of(cell, 40))
    # nominal 1 %: four or more of forty would happen with probability 0.8 %
    assert rate.hits <= 3, (cell.label(), rate.hits)


def test_a_clean_machine_gets_the_offsets_only_fit_when_nothing_is_claimed():
    for seed in range(12):
        obs = simulated_observations(DIAL, 100 + seed)
        d = diagnose(obs, separate=False)
        plain = fit(obs, PARAM_SETS["offsets"])
        if not d.effects:
            assert np.allclose(d.final_fit.values, plain.values, atol=1e-9, rtol=0)
        else:  # only past an inconsistent verdict
            assert not d.base.consistent
