"""The maps a calibration writes land each joint where it is commanded, once the
offsets written beside them are in force: checked against the physics, not against
ogacq's own model of it.

A scan of a machine whose x screw has a periodic error (and joint offsets of a
millimetre or so, as a machine has before its first calibration) is diagnosed; the
compensation is made from it (``compensation_of``); the offsets are stored as the
CiA 402 drive stores them (0.01 mm step). Then, over the whole travel, each target
goes through ogacq's correction (``TargetCorrection``) to the drive, and where the
joint really lands is computed by hand from the physics the readings were made
with: the drive puts the screw at ``p = q + o`` for a target q under offset o
(``q = p - o``: ogacq_drivers/axes/controller.py, the joint-offset convention of
MODEL.md: ``r = rho + drho``), and the joint is then at ``p + drho + A sin(2 pi p /
P + phase)`` (the effects file's ``lead_screw`` table, ogacq/sim/truth.py). It must
land on its target, up to one constant (what the offset register cannot hold), within
the map's own uncertainty: at the travel's ends as well, which the scan does not
reach and the offsets move.

A map left in the campaign's coordinate (the offsets moving the screw under it by
1.24 mm) was off by 2 pi 1.24 / 20 of phase there: 6 um peak to peak left of 16.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from ogacq.calibration.compensate import compensation_of
from ogacq.compensation.applied import TargetCorrection
from ogacq.diagnose.diagnosis import diagnose
from ogacq.io.machine_file import machine_dict
from ogacq.model.machine import PAPER_PROTOTYPE_DIGITAL
from ogacq.model.parameters import AXES, vector
from ogacq.protocol.plan import ProtocolConfig, planned_layout
from ogacq.session.convert import session_observations
from ogacq.session.store import LoadedSession, load_session
from ogacq.sim.readings import simulated_readings
from ogacq.sim.truth import LeadScrewError, SimTruth
from tests.writeback.conftest import write_layout_session

MACHINE = PAPER_PROTOTYPE_DIGITAL
AMPLITUDE_MM, PITCH_MM, PHASE_DEG = 0.008, 20.0, 30.0
DRHO = {"x": -1.2431, "y": -0.7896, "z": 0.9038}  # the simulator's seed 3
REGISTER_STEP_MM = 0.01  # the simulated CiA 402 drive's offset register


def register(value_mm: float) -> float:
    return round(round(value_mm / REGISTER_STEP_MM) * REGISTER_STEP_MM, 9)


def screw_error_mm(p_mm: np.ndarray) -> np.ndarray:
    """The x screw's error at its raw position, written here from the effects file's
    definition (A sin(2 pi q / pitch + phase)), not taken from ogacq."""
    return AMPLITUDE_MM * np.sin(2 * np.pi * p_mm / PITCH_MM + math.radians(PHASE_DEG))


def scan_session(path: Path) -> LoadedSession:
    """A finished scan (every leg, every 2.5 mm, both sides, two cycles) of the machine
    with the screw error, run with no offsets and no maps in force."""
    plan = ProtocolConfig(scan_step_mm=2.5, approach="both", cycles=2, postures=())
    lay = planned_layout(plan, MACHINE)
    assert lay.posture is not None  # a plan's layout names its postures
    truth = SimTruth(vector({f"joint_offset.{a}": v for a, v in DRHO.items()}),
                     lead_screw={0: LeadScrewError(AMPLITUDE_MM, PITCH_MM, PHASE_DEG)})
    obs = simulated_readings(MACHINE, lay, truth, scatter_mm=0.0006, step_mm=0.0001, seed=5)
    header = {"machine": machine_dict(MACHINE), "campaign_file": "synthetic",
              "station": {"controller": {"profile": "cia402", "port": "synthetic",
                                         "offsets_mm": dict.fromkeys(AXES, 0.0)}},
              "plan": plan.to_dict()}
    write_layout_session(path, header, lay, obs.values, "scan")
    return load_session(path)


def test_the_written_map_lands_the_joint_on_its_target_over_the_whole_travel(
        tmp_path: Path) -> None:
    session = scan_session(tmp_path / "scan.jsonl")
    diagnosis = diagnose(session_observations(session))
    assert [m.axis for m in diagnosis.maps] == ["x"], diagnosis.maps
    comp = compensation_of(diagnosis, session, MACHINE, register)
    m = comp.maps["x"]
    # the offsets the write stores (new = in force - identified, writeback.policy)
    o = {a: register(0.0 - comp.offsets_mm[a]) for a in AXES}
    assert abs(o["x"] - 1.24) < 0.015  # the screw moves 1.24 mm under the map

    targets = np.arange(MACHINE.rho_min_mm, MACHINE.rho_max_mm + 1e-9, 0.5)
    landed = []
    for order in (targets, targets[::-1]):  # approached moving up, then down
        correction = TargetCorrection(comp.maps, (MACHINE.rho_min_mm, MACHINE.rho_max_mm))
        correction.command((float(order[0]) - np.sign(order[-1] - order[0]), 0.0, 0.0))
        for q in order:
            sent = correction.command((float(q), 0.0, 0.0))[0]
            p = sent + o["x"]  # where the drive puts the screw
            landed.append(p + DRHO["x"] + screw_error_mm(np.array(p)) - q)
    off = np.array(landed)
    # one constant, where the map is zero (q = 0 approached forward): the joint offset's
    # error, the part of it the 0.01 mm register cannot hold included
    constant = float(off[np.flatnonzero(targets == 0.0)[0]])
    held = abs(0.0 - comp.offsets_mm["x"] - o["x"])
    assert abs(constant) <= held + 3 * comp.offsets_std_mm["x"] + 1e-4, (constant, held)
    # and about it, no more than the map's own uncertainty (k = 3; u is the map's
    # relative to its reference, as the constant is), and the table's chord between its
    # points: 1 - cos(pi / 20) of the amplitude, 0.1 um (error_maps.tabulation_step)
    u = np.interp(np.concatenate([targets, targets[::-1]]), m.positions_mm, m.u_forward_mm)
    left = np.abs(off - constant)
    assert np.all(left <= 3 * u + 1e-4), (float(np.max(left)) * 1e3, float(np.max(u)) * 1e3)
    assert np.max(left) < 0.1 * 2 * AMPLITUDE_MM  # of 16 um peak to peak, under 10 % left
    # the table reaches both ends of the travel in the new coordinate, zero at its q = 0
    assert m.positions_mm[0] <= MACHINE.rho_min_mm and m.positions_mm[-1] >= MACHINE.rho_max_mm
    assert m.reference_mm == 0.0 and abs(m.error_mm(0.0, 1)) < 1e-12
