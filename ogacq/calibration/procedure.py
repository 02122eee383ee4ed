"""``ogacq calibrate``, step by step, each step resumed after a kill.

    calibration campaign -> diagnosis -> (ambiguous: the separating measurement,
    shown with its duration, run, diagnosed) -> the compensation (offsets and maps,
    every table exported) -> shown, confirmed -> written (audited, read back) ->
    validation campaign (the same plan, and targets between the scan's) -> judged
    against the one before -> worse: the previous state restored, with the reason
    -> (worse between the scan's targets: a second round, once, within the scan's
    budget: the scan and that validation diagnosed together, written, validated;
    ``ogacq.calibration.second_round``) -> the record (as found, as left, the ISO
    230-2 figures) -> done

The second round's steps carry ``round: 2`` in the log; the first's carry none, so
each round finds its own steps on a resume.

Each step is run once through the procedure's journal (``ogacq.calibration.log``:
``ProcedureLog.once`` records its result, and hands the recorded one back on a resume);
a run that finds a log continues at the first step not done: a campaign stopped
half-way is resumed like any campaign, a write is planned again from what the
controller and the maps file hold (a write that completed before the kill has
nothing left to do, and its audit names it). On the simulator, the simulated
drives lost with the process are given back the offsets the session's audit says
they held: a real drive keeps its parameters when ogacq is killed.
"""

from __future__ import annotations

import contextlib
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any, Protocol

from ogacq_drivers.axes.profile import load_profile
from ogacq.calibration.compensate import (
    TABLES_FOLDER,
    Compensation,
    compensation_of,
    evidence_for,
)
from ogacq.calibration.drive_step import (
    drive_step_mm,
    finer_than_drive,
    predicted_with_step,
)
from ogacq.calibration.log import Details, ProcedureLog, Step
from ogacq.calibration.maps import compensable_effects, diagnosis_maps
from ogacq.calibration.resolving import RESOLVING, resolving_plan, why_read_more
from ogacq.calibration.scale_check import scale_check
from ogacq.calibration.scale_map import ScaleFit, fit_scale, with_scale_maps
from ogacq.calibration.second_round import (
    ROUND,
    TOGETHER,
    VALIDATION,
    VALIDATION_SCAN,
    RoundDone,
    second_validation,
    together_protocol,
    why_not,
)
from ogacq.calibration.separate import (
    SeparatingPlan,
    not_established,
    offsets_carried,
    seconds_per_step,
    separating_plan,
    steps_of,
)
from ogacq.calibration.setup import Setup
from ogacq.calibration.together import observations_together
from ogacq.calibration.validate import Judgement, judge, where_looked
from ogacq.calibration.validation_design import validation_plan
from ogacq.campaign.campaign_file import ControllerSpec
from ogacq.campaign.positioning import run_positioning, session_result
from ogacq.campaign.run import run_campaign
from ogacq.campaign.station import open_controller, simulator_endpoints, start_simulator
from ogacq.compensation.export import export_tables
from ogacq.diagnose.diagnosis import Diagnosis, DiagnosisError, diagnose
from ogacq.errors import InputError, Refused
from ogacq.identify.observations import Observations
from ogacq.io.atomic import write_atomically
from ogacq.logs import logger
from ogacq.model.parameters import AXES
from ogacq.protocol.plan import ProtocolConfig
from ogacq.protocol.positioning import PositioningResult, positioning_plan
from ogacq.protocol.runner import Observer
from ogacq.protocol.scan_design import sampled_band
from ogacq.record.document import build_record
from ogacq.session.convert import session_observations
from ogacq.session.store import LoadedSession, load_session
from ogacq.writeback.audit import AuditLog, operations
from ogacq.writeback.execute import WriteOptions
from ogacq.writeback.maps import MapsFile, MapsPlan
from ogacq.writeback.maps_binding import check_maps_in_force
from ogacq.writeback.maps_table import maps_checksum
from ogacq.writeback.offsets_target import ControllerOffsets
from ogacq.writeback.outcome import Stage, WriteOutcome
from ogacq.writeback.policy import ControllerFacts, OffsetPlan, WritePolicy, plan_write
from ogacq.writeback.write_target import (
    AnyTarget,
    TargetPlan,
    found_in_force,
    left_half_way,
    present,
    restore,
    write_in_force,
)

if TYPE_CHECKING:  # SQLAlchemy is imported when a history is used, not at start-up
    from ogacq.history.location import HistoryLocation

log = logger(__name__)
STARTED, FINISHED = "started", "finished"  # a campaign step's status


@dataclass
class Stopped(Exception):  # a round's end, not an error
    """A round writes nothing (refused, declined, nothing to correct): why."""

    outcome: WriteOutcome
    reason: str


class CalibrationUI(Protocol):
    """What the procedure shows and asks (the command line renders it)."""

    yes: bool  # confirmed beforehand (--yes): nothing is asked

    def say(self, text: str) -> None: ...
    def observer(self, role: str) -> Observer | None: ...
    def diagnosis(self, role: str, diagnosis: Diagnosis) -> None: ...
    def separation(self, plan: SeparatingPlan, speed: float | None) -> None: ...
    def compensation(self, comp: Compensation, offsets: OffsetPlan,
                     maps: MapsPlan | None) -> None: ...
    def confirm(self, question: str) -> bool: ...
    def validation(self, judgement: Judgement) -> None: ...
    def recorded(self, session_path: Path) -> None:
        """Write-backs or restores were made in the session: into the history now."""


@dataclass
class Outcome:
    folder: Path
    procedure: str
    outcome: WriteOutcome
    reason: str
    evidence: Path | None = None
    validation: Path | None = None
    record: dict[str, Any] | None = None
    details: dict[str, Any] = field(default_factory=dict)

    @property
    def exit_code(self) -> int:
        codes = {WriteOutcome.DECLINED: 1, WriteOutcome.REFUSED: 4, WriteOutcome.RESTORED: 4}
        return codes.get(self.outcome, 0)


def calibrate(setup: Setup, ui: CalibrationUI, *, resume: bool,
              calibration_session: Path | None = None,
              history: HistoryLocation | None = None) -> Outcome:
    """Run the procedure in ``setup.folder`` (``resume``: continue its log).
    ``calibration_session``: a finished campaign of this machine, in its present
    state, to start from (``ogacq demo`` hands over the one it ran). ``history``: the
    one the procedure records into, whose last maps state the maps file must hold."""
    log_ = ProcedureLog.reopen(setup.folder) if resume else \
        ProcedureLog.create(setup.folder, setup.describe())
    if calibration_session is not None:
        if not load_session(calibration_session).finished:
            raise InputError(calibration_session, "the campaign to start from did not finish")
        log_.once(Step.CAMPAIGN, lambda: {"session": str(calibration_session.resolve())},
                  role="calibration", status=FINISHED)
    try:
        done = log_.finished
        if done is not None:
            ui.say(f"calibration {log_.procedure} already finished: {done.details.get('outcome')}")
            return _outcome_of(setup.folder, log_.procedure, done.details)
        with _machine(setup) as stack:
            return Procedure(setup, ui, log_, stack, history).run()
    finally:
        log_.close()


def _machine(setup: Setup) -> contextlib.AbstractContextManager[Any]:
    """The simulator serving the whole procedure (None on a station)."""
    return contextlib.nullcontext() if setup.simulator is None else \
        contextlib.closing(start_simulator(setup.machine, setup.simulator))


class Procedure:
    def __init__(self, setup: Setup, ui: CalibrationUI, log_: ProcedureLog, stack: Any,
                 history: HistoryLocation | None = None) -> None:
        self.history = history
        self.setup = setup
        self.ui = ui
        self.log = log_
        self.stack = stack
        self.controller = self._controller_spec()
        self.facts = ControllerFacts.of(load_profile(self.controller.profile))
        # the drives' position step: every corrected target is rounded to it
        self.drive_step_mm = drive_step_mm(self.controller.profile)
        self.round = 1  # the write round: 2 after a first one shown wrong between targets
        # each axis scale's test before the first write, and what it found along its axis
        self.before: dict[str, PositioningResult] = {}
        self.scales: dict[str, ScaleFit] = {}
        # what the end says of a designed scan that found no map: the smallest cyclic
        # error it finds reliably ("validated" holds for errors below it unseen)
        self.unseen = ""

    # ------------------------------------------------------------------ the steps
    def run(self) -> Outcome:
        self._give_back_drive_state()
        self._check_maps_file()
        first = self._campaign("calibration", self.setup.protocol)
        # each axis scale's positioning test before anything is written: the cyclic error
        # it finds is that axis's map, known to the legs' diagnoses (each reading's joint
        # where that error put it), and its figures the "before" of the validation by it
        self.before = {a: self._positioning("before", a) for a in AXES
                       if a in self.setup.axis_scales}
        self.scales = self._scale_fits()
        evidence, diagnosis = first, self._diagnosis("calibration", first)
        plan = self._separation(diagnosis, first)
        unsettled = ""
        if plan.protocol is not None and self.setup.separate:
            scan = self._campaign("separating", plan.protocol)
            scanned = self._resolved(scan, self._diagnosis("separating", scan))
            # maps the scan cannot establish: the offsets go as far as their own
            # campaign carries them, the maps said to be not established
            carried = offsets_carried(diagnosis)
            unsettled = not_established(scanned, carried)
            if unsettled:
                self._note(unsettled)
                diagnosis = carried
            else:
                evidence, diagnosis = scan, scanned
        comp = self._compensation(diagnosis, evidence, maps=not unsettled)
        self.unseen = _unseen_below(plan, comp) if not unsettled else ""
        # at targets between the scan's: an aliased map, or an error its targets
        # sampled at one phase, fails there instead of confirming itself
        between = self._validation_plan(evidence, comp, diagnosis) \
            if evidence is not first and _plan_of(evidence).is_scan else None
        try:
            done = self._round(first, diagnosis, evidence, comp, between)
        except Stopped as stop:
            return self._end(stop.outcome, stop.reason)
        if done.between is not None and done.between.worse and done.comp.maps:
            try:
                done = self._second_round(first, evidence, done) or done
            except Stopped as stop:  # the first round's end stands, restored
                self._note(f"no second write ({stop.outcome}): {stop.reason}")
        return self._finish(done.comp, first, done.validation, done.judgement, done.written,
                            done.restored)

    def _resolved(self, scan: LoadedSession, scanned: Diagnosis) -> Diagnosis:
        """A pitch ``scan`` leaves unresolved or loose for the travel, or its fit not
        within the noise: its gaps read at other phases where --scan-minutes leaves the
        time (``resolving``), both diagnosed together."""
        machine = self.setup.machine
        read = _plan_of(scan)
        reason = why_read_more(scanned, machine)
        if reason is None:
            return scanned
        why, loose = reason
        more = resolving_plan(read, machine, loose)
        rate = seconds_per_step(scan)
        needed = steps_of(more, machine) * rate
        if steps_of(read, machine) * rate + needed > self.setup.scan_budget_s:
            self._note(f"{why}: reading the scan's gaps at other phases would take "
                       f"{needed / 60:.0f} more minutes of machine time, beyond "
                       f"--scan-minutes {self.setup.scan_budget_s / 60:g}")
            return scanned
        self._note(f"{why}: the scan's gaps are read at other phases "
                   f"({len(more.scan_targets_mm)} targets, about {needed / 60:.0f} minutes) "
                   "and both diagnosed together")
        extra = self._campaign(RESOLVING, more)
        together = together_protocol(read, more, machine)
        obs = with_scale_maps(observations_together([scan, extra]), self.scales)
        return self._diagnosed(f"separating + {RESOLVING}", obs,
                               sampled_band(together, machine),
                               f"{scan.path} + {extra.path}")

    def _validation_plan(self, evidence: LoadedSession, comp: Compensation,
                         diagnosis: Diagnosis) -> ProtocolConfig:
        """The scan validating ``comp``'s maps between the scan's targets (clear of a
        resolving scan's too: ``resolving.SHARES``), grown where a periodic map must be
        seen within --scan-minutes (``validation_design``); on a resume the plan its
        campaign started with."""
        started = self.log.last(Step.CAMPAIGN, role="validation-scan", status=STARTED)
        if started is not None:
            return ProtocolConfig.from_dict(dict(started.details["plan"]))
        rate = seconds_per_step(evidence)
        most = int(self.setup.scan_budget_s / rate) if rate > 0 else None
        return validation_plan(_plan_of(evidence), comp.maps, self.setup.machine,
                               diagnosis.noise.sigma_mm, most)

    def _round(self, first: LoadedSession, diagnosis: Diagnosis, evidence: LoadedSession,
               comp: Compensation, between: ProtocolConfig | None) -> RoundDone:
        """Write ``comp`` (shown, confirmed, read back, audited in the calibration
        campaign's session, whose record this is), validate it at the papers' postures
        and, ``between``, at targets the evidence did not read; restored when worse.
        Stopped where the write is refused, declined or has nothing to do."""
        for sentence in finer_than_drive(comp.maps, self.drive_step_mm):
            self._note(sentence)
        if comp.maps:
            self.ui.say(predicted_with_step(self.drive_step_mm))
        # a write confirmed and cut by a kill is undone before it is planned again
        written = _operations(self.log.once(
            Step.WRITTEN, lambda: self._approved_write(first, diagnosis, evidence, comp),
            cut=lambda: self._undo_half_written(first), round=self._round_key))
        before = {a: b for a, b in self.before.items() if a in comp.maps}
        # the calibration campaign's plan again: its record compares as found and as left
        role, role_between = ("validation", "validation-scan") if self.round == 1 \
            else (VALIDATION, VALIDATION_SCAN)
        validation = self._campaign(role, self.setup.protocol)
        judgement = self._judge(comp, first, validation, role)
        looked = [validation]
        between_judged = between_session = None
        if between is not None:
            between_session = self._campaign(role_between, between)
            between_judged = self._judge(comp, evidence, between_session, role_between)
            judgement = judgement.merged(between_judged)
            looked.append(between_session)
        checks = {a: scale_check(b, self._positioning("after", a), comp.maps[a])
                  for a, b in before.items()}
        judgement = replace(judgement.with_scales(checks, comp.maps, self.setup.machine),
                            looked=where_looked(looked, self.setup.machine))
        if checks:
            self.log.once(Step.SCALES, lambda: {"checks": {a: c.to_json()
                                                          for a, c in checks.items()}},
                          round=self._round_key)
        restored: dict[str, str | None] = {}
        if judgement.worse:
            restored = _operations(self.log.once(
                Step.RESTORED, lambda: self._restore(first, written, judgement),
                round=self._round_key))
        return RoundDone(comp, validation, judgement, written, restored, between_judged,
                         between_session)

    def _second_round(self, first: LoadedSession, scan: LoadedSession,
                      done: RoundDone) -> RoundDone | None:
        """The scan and the validation between its targets diagnosed together, written
        and validated once more (``ogacq.calibration.second_round``); None where it is
        not taken (said why), Stopped where its write is not made."""
        assert done.between_session is not None
        machine = self.setup.machine
        together = together_protocol(_plan_of(scan), _plan_of(done.between_session),
                                     machine)
        validation = second_validation(together, machine)
        why = why_not(scan, validation, machine, first, self.setup.scan_budget_s)
        if why:
            self._note(why)
            return None
        sessions = [scan, done.between_session]
        try:
            # each reading where its drive was sent, the joint there with its scale's error
            obs = with_scale_maps(observations_together(sessions), self.scales)
        except InputError as exc:
            self._note(f"no second round: {exc}")
            return None
        self._note("the first round's maps were wrong between the scan's targets ("
                   + "; ".join(done.between.reasons if done.between else ())
                   + ") and were restored; second round: the scan and that validation "
                   "diagnosed together")
        self.round = ROUND
        diagnosis = self._diagnosed(TOGETHER, obs, sampled_band(together, machine),
                                    " + ".join(str(s.path) for s in sessions))
        unresolved = diagnosis.mapped.search.unresolved if diagnosis.mapped else []
        corrects = diagnosis.maps or compensable_effects(diagnosis)
        if not diagnosis.final.consistent or unresolved or not corrects:
            self._note("no second write: the scan and its validation together "
                       + ("fit " + diagnosis.final.describe()
                          if not diagnosis.final.consistent else
                          "leave a pitch unresolved" if unresolved else "find nothing a "
                          "map corrects"))
            self.round = 1
            return None
        return self._round(first, diagnosis, scan, self._compensation(diagnosis, scan),
                           validation)

    def _check_maps_file(self) -> None:
        """The maps file holds what the history says this machine holds, before
        anything moves: not deleted, emptied, or another calibration's."""
        if self.controller.maps_file is not None:
            check_maps_in_force(MapsFile(self.controller.maps_file, self._owner).table(),
                                *self._owner, self.history)

    def _tell(self, step: Step, tell: Callable[[], object], details: Details,
              **key: Any) -> None:
        """``step`` told (``tell``) and recorded once: a resume does not tell it again."""
        def told() -> Details:
            tell()
            return details
        self.log.once(step, told, **key)

    def _note(self, text: str) -> None:
        """Something the end must say (maps not established), logged once."""
        self._tell(Step.NOTE, lambda: self.ui.say(text), {}, text=text)

    @property
    def _round_key(self) -> int | None:
        """What this round's steps carry in the log: the second its number, the first
        nothing (logs before a second round existed read the same)."""
        return self.round if self.round > 1 else None

    def _notes(self) -> list[str]:
        return [str(r.details["text"]) for r in self.log.steps if r.step == Step.NOTE]

    def _controller_spec(self) -> ControllerSpec:
        spec = self.setup.controller
        if self.stack is None:
            return spec
        endpoints, _ = simulator_endpoints(self.stack)
        return replace(endpoints, offsets_file=spec.offsets_file, maps_file=spec.maps_file)

    def _give_back_drive_state(self) -> None:
        """On a restarted simulator, the offsets its drives held when the process died
        (the audit of the session that wrote them); a real drive keeps its own. A write
        killed before its outcome was recorded may have reached the drive: it is given
        back its new values, the state a real drive may be left in that the procedure
        must then find written."""
        if self.stack is None or not self.log.steps:
            return
        held: dict[str, float] | None = None
        first = self.log.last(Step.CAMPAIGN, role="calibration")
        path = Path(first.details["session"]) if first is not None else None
        if path is not None and path.is_file():  # its audit holds the writes and restores
            for op in operations(load_session(path)):
                held = dict(op.old_mm if op.status == Stage.FAILED else op.new_mm) \
                    if op.held_mm is None else dict(op.held_mm)
        if held is None:
            return
        with open_controller(self.controller) as controller:
            if controller.profile.offset.kind == "software":
                return  # in the offset table file, which outlived the process
            controller.write_offsets(held)
            self.ui.say("simulator restarted: its drives hold the offsets they held before "
                        f"({', '.join(f'{a} {held[a]:+.4f}' for a in AXES)} mm)")

    def _campaign(self, role: str, protocol: ProtocolConfig) -> LoadedSession:
        def run() -> Details:
            campaign = self.setup.campaign(role, protocol)
            path = campaign.session
            if path.exists() and path.stat().st_size == 0:
                path.unlink()  # killed between creating the file and its first line
            if path.exists():
                session = load_session(path)
                if not session.finished:
                    self.ui.say(f"resuming the {role} campaign ({len(session.readings)} "
                                "readings on file)")
                    run_campaign(campaign, observer=self.ui.observer(role), resume=session,
                                 simulator=self.stack)
            else:
                self._started(role, path, protocol.to_dict())
                self.ui.say(f"{role} campaign: {path}")
                run_campaign(campaign, observer=self.ui.observer(role), simulator=self.stack)
            return {"session": str(path)}
        return load_session(self._finished(role, run))

    def _started(self, role: str, path: Path, plan: Details) -> None:
        self.log.once(Step.CAMPAIGN, lambda: {"session": str(path), "plan": plan},
                      role=role, status=STARTED)

    def _finished(self, role: str, run: Callable[[], Details]) -> Path:
        """The session of the campaign ``role``, ``run`` once (it records its start)."""
        return Path(self.log.once(Step.CAMPAIGN, run, role=role, status=FINISHED)["session"])

    def _scale_fits(self) -> dict[str, ScaleFit]:
        """What each axis scale's test before found along its axis (said, logged once)."""
        fits = {a: fit_scale(r) for a, r in self.before.items()}
        def tell() -> None:
            for fit in fits.values():
                self.ui.say(fit.sentence())
        if fits:
            self._tell(Step.SCALE_MAPS, tell, {"fits": {a: f.to_json() for a, f in fits.items()}})
        return fits

    def _positioning(self, when: str, axis: str) -> PositioningResult:
        """The ``axis``'s positioning test by its scale ``when`` ("before", "after") this
        round's write, run (or continued, or read back) in its own session; its figures
        less what the drive's rounding moved the joint."""
        role = f"positioning-{when}-{axis}" + ("" if self.round == 1 or when == "before"
                                                else f"-{self.round}")
        path = self.setup.folder / f"{role}.jsonl"

        def run() -> Details:
            campaign = self.setup.campaign(role, self.setup.protocol)
            plan = positioning_plan(self.setup.machine, axis, runs=self.setup.scale_runs,
                                    drive_step_mm=self.drive_step_mm)
            self._started(role, path, plan.to_json())
            self.ui.say(f"{when} the write: the {axis} axis's positioning test by its scale "
                        f"(ISO 230-2, {len(plan.targets_mm)} targets, {plan.runs} runs each "
                        f"way): {path}")
            run_positioning(campaign, plan, path, simulator=self.stack,
                            observer=self.ui.observer(role))
            return {"session": str(path)}
        return session_result(load_session(self._finished(role, run)), net_of_drive=True)

    def _diagnosis(self, role: str, session: LoadedSession) -> Diagnosis:
        # a designed scan's readings searched for the periods its targets sample
        band = sampled_band(_plan_of(session), self.setup.machine) \
            if session.header.plan is not None else None
        return self._diagnosed(role, with_scale_maps(session_observations(session),
                                                     self.scales), band, str(session.path))

    def _diagnosed(self, role: str, obs: Observations, band: tuple[float, float] | None,
                   source: str) -> Diagnosis:
        try:
            result = diagnose(obs, pitch_band_mm=band)
        except DiagnosisError as exc:
            raise InputError(source, str(exc)) from None
        self._tell(Step.DIAGNOSIS, lambda: self.ui.diagnosis(role, result), {
            "session": source, "outcome": result.outcome, "diagnosis": result.to_json(),
            "maps": [m.to_json() for m in diagnosis_maps(result)]}, role=role)
        return result

    def _separation(self, diagnosis: Diagnosis, session: LoadedSession) -> SeparatingPlan:
        plan = separating_plan(diagnosis, session, self.setup.machine,
                               self.setup.scan_protocol(),
                               designed=self.setup.scan_step_mm is None,
                               budget_s=self.setup.scan_budget_s,
                               grow=self.setup.scan_minutes is not None)
        speed = self.setup.simulator.speed if self.setup.simulator else None
        self._tell(Step.SEPARATION, lambda: self.ui.separation(plan, speed), {
            "run": plan.protocol is not None and self.setup.separate, **plan.to_json()})
        return plan

    def _compensation(self, diagnosis: Diagnosis, evidence: LoadedSession,
                      maps: bool = True) -> Compensation:
        """``maps``: False where the maps are not established (the offsets alone). As
        recorded: a resume carries on with the compensation it had made."""
        return Compensation.from_json(self.log.once(
            Step.COMPENSATION, lambda: self._compensate(diagnosis, evidence, maps).to_json(),
            round=self._round_key))

    def _compensate(self, diagnosis: Diagnosis, evidence: LoadedSession,
                    maps: bool) -> Compensation:
        # the maps go with the coordinate the offsets make, as the register stores them
        comp = compensation_of(diagnosis, evidence, self.setup.machine, self.facts.quantize,
                               self.scales)
        if not maps and not any(f.found for f in self.scales.values()):
            # no map stands on a campaign the separating scan contradicts (a scale's
            # does: it measured its axis itself)
            comp = tables_only(comp)
        title = (f"ogacq calibrate {self.log.procedure}: {self.setup.machine.name or 'machine'}"
                 f", from {evidence.path.name}")
        # the formats the controller names (None: every one)
        tables = export_tables(self.setup.folder / TABLES_FOLDER, comp.maps, title=title,
                               formats=self.controller.tables) if comp.maps else []
        comp = replace(comp, tables=[e.to_json() for e in tables])
        if comp.maps and self.controller.maps_file is None:
            self.ui.say("the controller names no maps_file: the maps are exported as tables "
                        "only (add maps_file to [controller] for ogacq to apply them); what "
                        "they would correct stays, and the offsets are written without them")
            comp = tables_only(comp)
        return comp

    def _plans(self, diagnosis: Diagnosis, evidence: LoadedSession, comp: Compensation,
               ) -> tuple[OffsetPlan, MapsPlan | None]:
        with self._targets() as (offsets_target, maps_target):
            offsets = plan_write(evidence_for(diagnosis, evidence, comp.shift_mm),
                                 offsets_target.held(), offsets_target.facts, WritePolicy())
        maps = None
        if comp.maps and maps_target is not None:
            maps = maps_target.plan_write(comp.maps, in_force_checksum=comp.in_force_checksum
                                          or maps_checksum({}))
        return offsets, maps

    @contextlib.contextmanager
    def _targets(self) -> Iterator[tuple[ControllerOffsets, MapsFile | None]]:
        """The controller's offsets (the controller open) and the maps file, if any."""
        spec = self.controller
        with open_controller(spec) as controller:
            yield (ControllerOffsets(controller, spec.offsets_file,
                                     WriteOptions(port=spec.port or None)),
                   MapsFile(spec.maps_file, self._owner) if spec.maps_file is not None
                   else None)

    @property
    def _owner(self) -> tuple[str, str]:
        """The machine the maps are bound to: its name and serial."""
        return self.setup.machine.name, self.setup.machine.serial

    def _undo_half_written(self, audited: LoadedSession) -> None:
        """A write of this procedure killed half-way (x and y written, z not yet) left
        a state that is its own, not a later change: its old values are put back,
        audited, so that the write is planned again from the state it replaced."""
        session = load_session(audited.path)
        undone = False
        with AuditLog(session) as audit, self._targets() as targets:
            for target in present(*targets):
                ops = target.operations(session)
                held = target.held()
                half = left_half_way(target, ops, held)
                if half is None or write_in_force(target, ops, held) is not None \
                        or target.same(held, half.old_state):
                    continue
                self.ui.say(f"the {target.noun} hold what {half.operation} left "
                            f"half-way ({target.describe(held)}): its old values are put "
                            "back before it is written again")
                restore(target, half, session, audit, "calibrate (own write cut half-way)")
                undone = True
        if undone:
            self.ui.recorded(audited.path)

    def _approved_write(self, first: LoadedSession, diagnosis: Diagnosis,
                        evidence: LoadedSession, comp: Compensation) -> Details:
        """Planned from what the controller and the maps file hold (again on a resume:
        it may have moved), shown and confirmed once, written."""
        offsets, maps = self._plans(diagnosis, evidence, comp)
        confirmed = self.log.once(Step.CONFIRMED, lambda: self._approve(comp, offsets, maps),
                                  round=self._round_key)
        return self._write(first, offsets, maps, str(confirmed.get("by", "prompt")))

    def _approve(self, comp: Compensation, offsets: OffsetPlan,
                 maps: MapsPlan | None) -> Details:
        """Shown and confirmed: by whom; else Stopped (the end's outcome and reason)."""
        self.ui.compensation(comp, offsets, maps)
        refusals = [*offsets.refusals, *(maps.refusals if maps else ())]
        mark = {"round": self._round_key} if self._round_key else {}
        if refusals:
            self.log.add(Step.REFUSED, **mark, reasons=[r.message for r in refusals],
                         codes=[r.code for r in refusals])
            raise Stopped(WriteOutcome.REFUSED, "; ".join(r.message for r in refusals))
        if offsets.nothing_to_do and (maps is None or maps.nothing_to_do):
            raise Stopped(WriteOutcome.NOTHING_TO_CORRECT, "the controller and the maps "
                          "file already hold what this calibration would write")
        if not self.ui.yes and not self.ui.confirm("Write these offsets and maps?"):
            self.log.add(Step.DECLINED, **mark)
            raise Stopped(WriteOutcome.DECLINED, "the operator declined the write")
        return {"by": "--yes" if self.ui.yes else "prompt"}

    def _write(self, audited: LoadedSession, offsets: OffsetPlan, maps: MapsPlan | None,
               by: str) -> Details:
        # planned again on a resume: what the controller and the file hold may have moved
        refusals = [*offsets.refusals, *(maps.refusals if maps else ())]
        if refusals and not (offsets.nothing_to_do and (maps is None or maps.nothing_to_do)):
            raise Refused("nothing written: " + "; ".join(r.message for r in refusals))
        written: dict[str, str | None] = {"offsets": None, "maps": None}
        session = load_session(audited.path)
        try:
            with AuditLog(session) as audit, self._targets() as (offsets_target, maps_target):
                written["offsets"] = _write_once(offsets_target, offsets, session, audit, by)
                if maps_target is not None and maps is not None:
                    written["maps"] = _write_once(maps_target, maps, session, audit, by)
        finally:
            self.ui.recorded(audited.path)
        self.ui.say("written: " + ", ".join(f"{k} ({v})" for k, v in written.items() if v))
        return written

    def _judge(self, comp: Compensation, before: LoadedSession, validation: LoadedSession,
               role: str) -> Judgement:
        judgement = judge(comp, before, validation, self.setup.machine, self.facts.resolution_mm,
                          self.drive_step_mm)
        self._tell(Step.VALIDATION, lambda: self.ui.validation(judgement), {
            "session": str(validation.path), "before": str(before.path),
            **judgement.to_json()}, role=role)
        return judgement

    def _restore(self, audited: LoadedSession, written: dict[str, str | None],
                 judgement: Judgement) -> Details:
        """Put back what the procedure wrote, each said restored only once read back."""
        reason = "; ".join(judgement.reasons)
        self.ui.say(f"the validation is worse than before: {reason}. Restoring the previous "
                    "state")
        session = load_session(audited.path)
        restored: dict[str, str | None] = {"offsets": None, "maps": None}
        try:
            with AuditLog(session) as audit, self._targets() as targets:
                for target in present(*targets):
                    if written.get(target.noun):
                        op = next(o for o in target.operations(session)
                                  if o.operation == written[target.noun])
                        restored[target.noun] = restore(target, op, session, audit,
                                                        "calibrate (validation worse)")
        finally:
            self.ui.recorded(audited.path)
        return {"reason": reason, **restored}

    def _finish(self, comp: Compensation, evidence: LoadedSession, validation: LoadedSession,
                judgement: Judgement, written: dict[str, str | None],
                restored: dict[str, str | None]) -> Outcome:
        outcome = WriteOutcome.RESTORED if judgement.worse else WriteOutcome(judgement.outcome)
        reason = "; ".join(judgement.reasons) if judgement.worse else (
            "; ".join(["the validation is within the gauge noise " + judgement.looked
                       + ("" if outcome == WriteOutcome.VALIDATED else
                          ", but its test would not see every correction go wrong"),
                       *judgement.seen()])
            if outcome in (WriteOutcome.VALIDATED, WriteOutcome.NOT_SHOWN) else
            "better than before, but not within the gauge noise: " + judgement.verdict["text"])
        reason = "; ".join([reason, *self._notes(), *filter(None, [self.unseen])])
        return self._end(outcome, reason, comp=comp, evidence=evidence, validation=validation,
                         judgement=judgement, written=written, restored=restored)

    def _end(self, outcome: WriteOutcome, reason: str, *, comp: Compensation | None = None,
             evidence: LoadedSession | None = None, validation: LoadedSession | None = None,
             judgement: Judgement | None = None, written: dict[str, str | None] | None = None,
             restored: dict[str, str | None] | None = None) -> Outcome:
        head = {"procedure": self.log.procedure, "outcome": outcome, "reason": reason,
                "writes": written or {}, "restores": restored or {}}
        details: dict[str, Any] = dict(head)
        if outcome in NOT_APPLIED:
            mark_tables_not_applied(self.setup.folder / TABLES_FOLDER, self.log.procedure,
                                    outcome, reason)
        record = None
        if comp is not None and evidence is not None:
            details.update(compensation=comp.to_json(),
                           validation=judgement.to_json() if judgement else None)
            summary = {**head, "maps": {a: {"source": m.source, "checksum": m.checksum()}
                                        for a, m in comp.maps.items()},
                       "compensated": list(comp.compensated),
                       "uncompensated": list(comp.uncompensated),
                       "iso230_2": {"before": comp.figures_before(),
                                    "after": judgement.figures_after if judgement else {}},
                       "offsets": {"corrected_mm": comp.offsets_mm,
                                   "left_mm": judgement.offsets_after_mm if judgement else None},
                       "tables": comp.tables}
            record = build_record(load_session(evidence.path), validation=validation,
                                  compensation=summary)
            details["validation_record"] = validation.path.name if validation else None
        self.log.add(Step.FINISHED, outcome=outcome, reason=reason,
                     record_id=record["id"] if record else None,
                     evidence=str(evidence.path) if evidence else None,
                     validation=str(validation.path) if validation else None)
        return Outcome(self.setup.folder, self.log.procedure, outcome, reason,
                       evidence.path if evidence else None,
                       validation.path if validation else None, record, details)


def _unseen_below(plan: SeparatingPlan, comp: Compensation) -> str:
    """Where a designed separating scan left no map to write: the cyclic error it finds
    reliably, below which one may remain."""
    words = plan.design.may_remain() if plan.design is not None and not comp.maps else ""
    return f"no error map: {words}" if words else ""


# Outcomes after which the exported tables hold maps no controller runs with.
NOT_APPLIED = (WriteOutcome.REFUSED, WriteOutcome.DECLINED, WriteOutcome.RESTORED)
NOT_APPLIED_FILE = "NOT-APPLIED.txt"


def mark_tables_not_applied(tables: Path, procedure: str, outcome: WriteOutcome,
                            reason: str) -> None:
    """Say, beside the exported tables, that they were not applied: they stay as the
    evidence of what was proposed, and a technician who finds them must not load them
    into a controller."""
    if not tables.is_dir():
        return
    write_atomically(tables / NOT_APPLIED_FILE, (
        f"NOT APPLIED. These compensation tables were computed by ogacq calibrate "
        f"{procedure}, which ended {outcome}: {reason}.\n"
        "Do not load them into a controller: the machine does not run with them.\n"
        "They are kept as the evidence of what was proposed.\n").encode())


def tables_only(comp: Compensation) -> Compensation:
    """The compensation when its maps cannot be applied (exported only): nothing of it
    is written but the offsets, without the maps' constants, and what the maps would
    correct stays uncompensated (the validation expects it still there)."""
    return replace(comp, maps={}, shift_mm=dict.fromkeys(comp.shift_mm, 0.0),
                   compensated=(), uncompensated=comp.uncompensated + comp.compensated,
                   offsets_mm={a: v - comp.shift_mm.get(a, 0.0)
                               for a, v in comp.offsets_mm.items()})


def _plan_of(session: LoadedSession) -> ProtocolConfig:
    if session.header.plan is None:
        raise InputError(session.path, "this session has no plan: it was not recorded by a "
                         "campaign")
    return ProtocolConfig.from_dict(dict(session.header.plan))


def _write_once(target: AnyTarget, plan: TargetPlan, session: LoadedSession,
                audit: AuditLog, confirmed_by: str) -> str | None:
    """Carry ``plan`` out, unless the target holds its values already: then the write
    that left them (done, or killed before its ``done`` record) is the one made."""
    if not plan.nothing_to_do:
        return target.execute(plan, audit, confirmed_by)
    op = found_in_force(target, session, audit)
    return op.operation if op is not None else None


def _outcome_of(folder: Path, procedure: str, d: Details) -> Outcome:
    """A finished procedure's outcome, as its log's end says."""
    return Outcome(folder, procedure, WriteOutcome(d["outcome"]), str(d.get("reason")),
                   Path(d["evidence"]) if d.get("evidence") else None,
                   Path(d["validation"]) if d.get("validation") else None)


def _operations(details: Details) -> dict[str, str | None]:
    """The operation (its audit's name) a write or a restore made on each target, as its
    step recorded it (None: none)."""
    return {noun: details.get(noun) for noun in ("offsets", "maps")}
