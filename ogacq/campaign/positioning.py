"""Running an ISO 230-2 positioning test of one axis by its scale, end to end: the
station opened as a campaign opens it (its controller homed and checked before any
set-point, the maps in force applied to every target), each move and each scale
reading appended to a session as it comes (a kill loses nothing on file; the same
call continues it, approaching the next target from its side), the figures of its
readings (``ogacq.protocol.positioning``).

Only the tested joint moves; the others are held at their zero. The targets lie within
the travel less the overrun, which the controller's soft limits hold.
"""

from __future__ import annotations

import dataclasses
import json
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ogacq.campaign.campaign_file import AxisScaleSpec, Campaign
from ogacq.campaign.run import check_same_maps, maps_in_force, target_correction
from ogacq.campaign.station import DeviceStation, open_station
from ogacq.campaign.traceability import check_instruments, header_entries
from ogacq.compensation.applied import TargetCorrection
from ogacq.errors import InputError
from ogacq.io.atomic import write_atomically
from ogacq.io.machine_file import machine_dict
from ogacq.model.parameters import AXES
from ogacq.protocol.positioning import (
    SESSION_KIND,
    PositioningPlan,
    PositioningStep,
    session_result,
)
from ogacq.protocol.runner import Observer, Progress, run_to_end
from ogacq.session.records import (
    MoveRecord,
    OverrideRecord,
    PositionRecord,
    SettleRecord,
)
from ogacq.session.store import LoadedSession, SessionWriter, check_writable, load_session

if TYPE_CHECKING:
    from ogacq.sim.stack import SimulatorStack

def run_positioning(campaign: Campaign, plan: PositioningPlan, session_path: Path, *,
                    simulator: SimulatorStack | None = None,
                    observer: Observer | None = None) -> LoadedSession:
    """Run (or continue) the test ``plan`` into ``session_path``; the finished session.
    Raises CampaignStopped (recorded, resumable) when a device fails."""
    resume = load_session(session_path) if session_path.exists() else None
    if resume is not None and resume.header.kind != SESSION_KIND:
        raise InputError(session_path, "is not a positioning test's session")
    if resume is not None and resume.finished:
        return resume
    check_writable(session_path, resuming=resume is not None)
    # the scale within its certificate on the test's date, or overridden with a reason
    scale = campaign.axis_scales.get(plan.axis)
    overrides = check_instruments(dataclasses.replace(
        campaign, gauges=[scale.as_gauge(plan.axis)] if scale is not None else [],
        extra_instruments=[]), overridden=[
            r.subject for r in resume.of_type(OverrideRecord)] if resume is not None else ())
    maps = maps_in_force(campaign)
    if resume is not None:
        check_same_maps(resume, maps)
    with open_station(campaign, simulator) as station:
        station.prepare()
        if maps is not None:  # the identity of the maps every target is corrected with
            station.description["controller"]["maps"] = maps.identity()
        header = {"kind": SESSION_KIND, "machine": machine_dict(campaign.machine),
                  "machine_file": str(campaign.machine_path),
                  "campaign_file": str(campaign.path.resolve()),
                  "simulated": station.description["simulated"],
                  "station": station.description, "positioning": plan.to_json(),
                  **_traceability(campaign, plan.axis, station.description)}
        writer = SessionWriter.reopen(resume) if resume is not None \
            else SessionWriter.create(session_path, header)
        with writer:
            for record in overrides:
                writer.write(record)
            station.record_event = writer.write
            done = {(r.run, r.direction, round(r.target_mm, 6))
                    for r in (resume.of_type(PositionRecord) if resume else ())}
            test = _Test(station, writer, plan, campaign, done,
                         target_correction(campaign, maps), observer)
            run_to_end(test.run_steps, station, writer, lambda: len(done))
    return load_session(session_path)


def _traceability(campaign: Campaign, axis: str, station: dict[str, Any]) -> dict[str, Any]:
    """The header's identity (machine, operator), date and the scale as the test's
    instrument: its identity and certificate as the campaign file gives them, the
    serial the station opened it with otherwise (the simulator's), its display step."""
    entries = header_entries(dataclasses.replace(campaign, gauges=[], extra_instruments=[]),
                             {})
    opened = station["axis_scales"][axis]
    gauge = (campaign.axis_scales.get(axis) or AxisScaleSpec()).as_gauge(axis)
    gauge = dataclasses.replace(gauge, serial=gauge.serial or str(opened["serial"] or ""))
    return entries | {"instruments": [gauge.instrument(opened["resolution_mm"]).to_json()]}


@dataclass
class _Test:
    station: DeviceStation
    writer: SessionWriter
    plan: PositioningPlan
    campaign: Campaign
    done: set[tuple[int, int, float]]
    correction: TargetCorrection | None
    observer: Observer | None

    def run_steps(self) -> None:
        steps = list(self.plan.steps())
        lo, hi = min(self.plan.targets_mm), max(self.plan.targets_mm)
        # continued: the first target left is approached from its run's own start
        from_side = bool(self.done)
        for step in steps:
            if step.read and step.key in self.done:
                continue
            if not step.read:
                if self._run_done(steps, step):
                    continue
                self._move(step.target_mm, "overrun")
                from_side = False
                continue
            if from_side:
                start = lo - self.plan.overrun_mm if step.direction > 0 \
                    else hi + self.plan.overrun_mm
                self._move(start, "overrun")
                from_side = False
            self._read(step, *self._move(step.target_mm, "positioning"))

    def _run_done(self, steps: list[PositioningStep], overrun: PositioningStep) -> bool:
        """Every reading of the run and direction this overrun starts is on file."""
        return all(s.key in self.done for s in steps
                   if s.read and (s.run, s.direction) == (overrun.run, overrun.direction))

    def _move(self, target_mm: float, purpose: str) -> tuple[float, float]:
        """The tested joint to ``target_mm`` (through the maps in force); the target the
        drive took, and where that meant the joint to land."""
        q = self.plan.q_of(target_mm)
        sent = self.correction.command(q) if self.correction is not None else q
        resolved = self.station.move(sent, self.campaign.protocol.move_timeout_s)
        meant = self.correction.nominal(q, resolved) if self.correction is not None \
            else resolved
        self.writer.write(MoveRecord(q_mm=meant, purpose=purpose, commanded_mm=resolved))
        a = AXES.index(self.plan.axis)
        return resolved[a], meant[a]

    def _read(self, step: PositioningStep, commanded_mm: float, meant_mm: float) -> None:
        described = self.station.description["axis_scales"][self.plan.axis]
        rule = dataclasses.replace(self.campaign.protocol.settle_rule, kind="stable",
                                   display_step_mm=described["resolution_mm"])
        value, settled = self.station.read_scale(self.plan.axis, rule,
                                                 self.campaign.protocol.stability)
        name = f"{self.plan.axis}/r{step.run}/{'up' if step.direction > 0 else 'down'}" \
               f"/{step.target_mm:+.3f}"
        self.writer.write(SettleRecord(step=name, rule="stable",
                                       ended="stable" if settled.value else "bound",
                                       waited_s=round(settled.waited_s, 4)))
        self.writer.write(PositionRecord(
            axis=self.plan.axis, run=step.run, direction=step.direction,
            target_mm=step.target_mm, commanded_mm=commanded_mm, meant_mm=meant_mm,
            scale_mm=value.value_mm,
            t_s=round(self.station.campaign_time_s(), 3), raw=value.raw,
            averaged=value.averaged, averaged_sd_mm=value.averaged_sd_mm))
        self.done.add(step.key)
        if self.observer is not None:
            self.observer(Progress(len(self.done), self.plan.readings,
                                   f"{name}: scale {value.value_mm:+.4f} mm"))


def positioning_document(session: LoadedSession, drive_step_mm: float) -> dict[str, Any]:
    """What ``ogacq positioning --json`` prints and writes beside the session: the plan,
    the figures actual minus target, and (where maps were in force and the drive rounds
    its targets) the figures less that rounding, with the drive's step."""
    raw = session_result(session)
    out: dict[str, Any] = {"session": str(session.path),
                           "simulated": bool(session.header.simulated),
                           "plan": session.header.positioning or {},
        "drive_step_mm": drive_step_mm, **raw.to_json()}
    net = session_result(session, net_of_drive=True)
    if not np.allclose(net.mean_mm, raw.mean_mm, atol=1e-9):
        out["net_of_drive_step"] = net.to_json()
    return out


def write_document(session: LoadedSession, document: dict[str, Any]) -> Path:
    """The document as JSON beside the session (its name, ``.json``), whole or not."""
    path = session.path.with_suffix(".json")
    write_atomically(path, (json.dumps(document, indent=1) + "\n").encode("utf-8"))
    return path
