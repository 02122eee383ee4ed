"""The wizard from start to result: connect, machine, measure, result; a step
retried or skipped with a reason, Ctrl-C a pause, a stop said with what to do."""

from __future__ import annotations

import contextlib
import datetime
import re
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from ogacq_drivers.errors import DriverError
from ogacq_drivers.indicators import DEFAULT_PROTOCOL
from ogacq.campaign.campaign_file import (
    AxisEndpoint,
    Campaign,
    ControllerSpec,
    EnvironmentSpec,
    GaugeSpec,
    SimulatorSpec,
)
from ogacq.campaign.guided import (
    Rehearsal,
    campaign_file_text,
    rehearsal_controller_file,
    run_guided,
    start_rehearsal,
)
from ogacq.campaign.inventory import KnownGauge, load_inventory, unreadable_inventory
from ogacq.campaign.run import CampaignOutcome, gauges_read_by_eye
from ogacq.campaign.station import DeviceStation
from ogacq.campaign.traceability import simulated_gauges
from ogacq.cli.campaign_end import CampaignEnd, NextStep, campaign_end
from ogacq.cli.options import DEFAULT_SEED, DEFAULT_SPEED
from ogacq.cli.plain import shown
from ogacq.cli.verdict_text import one_line
from ogacq.cli.wizard.by_eye import ByEyeReadings, ReadingCounter
from ogacq.cli.wizard.connect import (
    StationChoice,
    check_controller,
    connect_instruments,
    describe_gauge,
    detect_ports,
    gauges_of,
    test_read,
)
from ogacq.cli.wizard.gauge_setting import LegSetter, RunHandles
from ogacq.cli.wizard.guided_station import GuidedStation
from ogacq.cli.wizard.pause import InterruptGate, OperatorQuit, closed_is_quit, pausable, pause_menu
from ogacq.cli.wizard.progress import CycleProgress
from ogacq.cli.wizard.result import offer_report, offer_writeback, show_result
from ogacq.cli.wizard.traceability import Indicator, Traceability, TraceabilityQuestions
from ogacq.cli.wizard.ui import (
    InputClosed,
    Option,
    Screen,
    detail,
    log_on_screen,
    times,
    typed_number,
)
from ogacq.history.recording import record_campaign
from ogacq.identify.consistency import fit_verdict
from ogacq.io.atomic import write_atomically
from ogacq.io.errors import InputError
from ogacq.io.machine_file import read_machine, write_machine
from ogacq.model.expected_readings import ReadingExpectations
from ogacq.model.machine import (
    PAPER_PROTOTYPE,
    PAPER_PROTOTYPE_DIGITAL,
    PAPER_PROTOTYPE_DIGITAL_NOTE,
    MachineSpec,
)
from ogacq.protocol import runner
from ogacq.protocol.plan import ProtocolConfig, SetGauges, StabilityRule, reading_steps
from ogacq.protocol.runner import CampaignStopped
from ogacq.protocol.station import Station
from ogacq.session.convert import session_machine
from ogacq.session.identification import identify_session
from ogacq.session.offsets_in_force import stations
from ogacq.session.records import (
    EnvironmentRecord,
    FaultRecord,
    OperatorRecord,
    ReadingRecord,
)
from ogacq.session.series import next_session
from ogacq.session.store import LoadedSession, SessionWriter, check_writable, load_session
from ogacq.sim.faults import FaultInjector, FaultPlan

EXIT_DONE = 0
EXIT_QUIT = 130


@dataclass
class WizardOptions:
    simulator: bool = False
    seed: int = DEFAULT_SEED
    speed: float = DEFAULT_SPEED
    profile: str = "cia402"
    machine: Path | None = None
    out: Path | None = None
    cycles: int = 3
    settle_s: float = 1.0
    stability_timeout_s: float = 10.0
    gauge_range_mm: float = 12.7
    max_offset_mm: float = 2.0
    by_eye: bool = False
    indicators: int | None = None  # 6 (left in place) or 2 (moved leg to leg); None: asked
    gauge_protocol: str = DEFAULT_PROTOCOL  # what a rehearsal's simulated gauges speak
    faults: list[FaultPlan] = field(default_factory=list)
    resume: Path | None = None
    history: str | None = None  # --history: where the finished campaign is recorded


def run_wizard(options: WizardOptions) -> int:
    screen = Screen()
    gate = InterruptGate()
    gate.install()
    try:
        with log_on_screen(screen):
            return _Wizard(screen, gate, options).run()
    except InputClosed:
        screen.stop_live()
        screen.say("\nThe terminal closed: the wizard stops here.")
        return EXIT_QUIT
    finally:
        screen.stop_live()
        gate.uninstall()


class _Wizard:
    def __init__(self, screen: Screen, gate: InterruptGate, options: WizardOptions) -> None:
        self.screen = screen
        self.gate = gate
        self.options = options
        self.session_path: Path | None = None
        self.by_eye: set[str] = set()
        self.rehearsal: Rehearsal | None = None
        self.injector: FaultInjector | None = None
        self._notes_for_session: list[OperatorRecord] = []  # written at the next run
        self.resumable_by_ogacq = False  # the campaign file alone continues the session
        self.campaign: Campaign | None = None
        self.folder: NewFolder | None = None  # a new campaign's, until it holds a session
        self.questions: TraceabilityQuestions | None = None

    # ====================================================================== top level
    def run(self) -> int:
        try:
            return self._run()
        finally:
            if self.folder is not None and (self.session_path is None
                                            or not self.session_path.exists()):
                self.folder.remove()  # an abandoned start leaves nothing behind

    def _run(self) -> int:
        with contextlib.ExitStack() as cleanup:
            try:
                if self.options.resume is not None:
                    outcome = self._continue(cleanup, self.options.resume)
                else:
                    outcome = self._new_campaign(cleanup)
            except OperatorQuit:
                self._say_quit()
                return EXIT_QUIT
            return self._finish(outcome)

    def _finish(self, outcome: CampaignOutcome) -> int:
        """Step 4: the result, then the write-back, the record and a validation offered."""
        s = self.screen
        s.heading("Result", "step 4 of 4")
        rehearsal = self.rehearsal is not None
        end = campaign_end(outcome.session_path, outcome.fit, simulated=rehearsal,
                           rehearsal_writeback=rehearsal)
        writable = show_result(s, outcome, end.record)
        # the session is closed and safe: a history that fails only warns
        record_campaign(outcome.session_path, self.options.history,
                        say=lambda text: s.say(shown(text)), record=end.built)
        controller_file = (rehearsal_controller_file(self.campaign, self.rehearsal)
                           if self.rehearsal is not None and self.campaign is not None else None)
        written = False
        try:
            written = offer_writeback(s, outcome.session_path, writable, controller_file,
                                      rehearsal=rehearsal, history=self.options.history)
        except (KeyboardInterrupt, OperatorQuit):
            s.say("\nNot written" + (" (rehearsal: the simulated controller stops with the "
                                     "wizard)." if rehearsal else
                                     f". Later: ogacq offsets write "
                                     f"{shown(outcome.session_path)}"))
        folder = outcome.session_path.parent / "report"
        report: Path | None = None
        validation: CampaignOutcome | None = None
        # Ctrl-C at an offer below pauses (it quit without a word, the verdict, the
        # record id and the next commands unsaid); a quit there ends with them
        try:
            report = pausable(s, "before the calibration record", lambda: offer_report(
                s, outcome.session_path, folder, history=self.options.history))
            if written and self.campaign is not None:
                validation = self._offer_validation(outcome)
            if validation is not None and report is not None:
                as_left = validation.session_path
                report = None  # until issued as found and as left
                report = pausable(s, "before the record as found and as left",
                                  lambda: offer_report(s, outcome.session_path, folder,
                                                       as_left, self.options.history))
        except OperatorQuit:
            if self.session_path != outcome.session_path:  # inside the validation campaign
                self._say_quit()
                return EXIT_QUIT
            stopped = True
        else:
            stopped = False
        self._say_end(replace(end, steps=self._next_steps(end, outcome, written, validation,
                                                          report), report=report), validation)
        if stopped:
            s.say("Stopped here: the campaign is complete and saved; what is left to do is "
                  "above.")
            return EXIT_QUIT
        s.say("[bold green]Calibration campaign complete.[/]")
        return EXIT_DONE

    def _say_end(self, end: CampaignEnd, validation: CampaignOutcome | None) -> None:
        """The verdict, the validation's beside it (the machine as left: the calibration's
        alone read as the last word), the record's id and the next commands."""
        lines = end.lines()
        if validation is not None:
            lines.insert(1, f"validation: {one_line(fit_verdict(validation.fit))} "
                            f"({validation.session_path})")
        self.screen.say()
        for line in lines:
            self.screen.say(shown(line), soft_wrap=True)

    def _offer_validation(self, calibration: CampaignOutcome) -> CampaignOutcome | None:
        """The same plan run again, the offsets as written: what remains (ISO/IEC
        17025:2017 7.8.4.1 d, results before and after an adjustment). Into the next
        session of the campaign's series (``session-2.jsonl``)."""
        s = self.screen
        assert self.campaign is not None
        if not pausable(s, "before the validation campaign", lambda: s.confirm(
                "Run a validation campaign now (the same plan, the offsets as written: what "
                "remains of them)?", default=True)):
            s.say("Not run. Later, with the gauges in place: [bold]"
                  + shown(f"ogacq run {self.campaign.path}") + "[/]"
                  + (" (on the machine: the rehearsal's simulator stops with the wizard)"
                     if self.rehearsal is not None else ""))
            return None
        chosen = next_session(self.campaign.session)
        campaign = replace(self.campaign, session=chosen.path)
        self.session_path = chosen.path
        header = load_session(calibration.session_path).header.wizard
        s.say(f"Validation campaign, recorded in {shown(chosen.path)}.")
        outcome = self._measure(campaign, None, dict(header) if header is not None
                                else {})
        s.heading("Validation", "what remains after the write-back")
        end = campaign_end(outcome.session_path, outcome.fit,
                           simulated=self.rehearsal is not None)
        show_result(s, outcome, end.record, title="Offsets remaining after the write-back",
                    truth=False)
        record_campaign(outcome.session_path, self.options.history,
                        say=lambda text: s.say(shown(text)), record=end.built)
        return outcome

    def _next_steps(self, end: CampaignEnd, outcome: CampaignOutcome, written: bool,
                    validation: CampaignOutcome | None, report: Path | None,
                    ) -> tuple[NextStep, ...]:
        """What is left to do once the wizard's own offers are answered."""
        session = outcome.session_path
        after = f" --after {validation.session_path}" if validation is not None else ""
        what = "the record as found and as left" if validation is not None \
            else "the calibration record"
        steps = [NextStep(f"open {report}", what) if report is not None
                 else NextStep(f"ogacq report {session}{after}", what)]
        if end.verdict.state == "inconsistent":
            steps.insert(0, NextStep(f"ogacq diagnose {session}", "what the joint offsets "
                                     "leave out: look before writing anything"))
        elif not written and end.verdict.consistent and self.rehearsal is not None:
            steps.append(NextStep("", "a rehearsal: the simulated controller stops with the "
                                      "wizard; on the machine, `ogacq offsets write SESSION` "
                                      "then a validation run"))
        elif not written and end.verdict.consistent:
            steps.append(NextStep(f"ogacq offsets write {session}", "write the offsets "
                                  "(shown and confirmed first)"))
        elif written and validation is None and self.campaign is not None \
                and self.rehearsal is None:
            steps.append(NextStep(f"ogacq run {self.campaign.path}", "a validation run, "
                                  "the offsets as written"))
        return tuple(steps)

    def _new_campaign(self, cleanup: contextlib.ExitStack) -> CampaignOutcome:
        opts = self.options
        self.folder = NewFolder.make(opts.out)
        folder = self.folder.path
        s = self.screen
        s.say("[bold]ogacq wizard[/]: a guided calibration of the joint offsets.")
        s.say("Four steps: connect the instruments, confirm the machine, set the gauges and "
              "measure each leg, then the result.")
        s.say("[dim]Ctrl-C pauses at any time: you can then resume or quit, nothing measured "
              "is lost.[/]")
        machine, machine_path = self._initial_machine(folder)
        protocol = ProtocolConfig(cycles=opts.cycles, settle_s=opts.settle_s,
                                  stability=StabilityRule(timeout_s=opts.stability_timeout_s))
        if opts.simulator:
            assert machine is not None and machine_path is not None
            sim = SimulatorSpec(seed=opts.seed, speed=opts.speed, profile=opts.profile,
                                gauge_layout="moved" if opts.indicators == 2 else "separate",
                                gauge_protocol=opts.gauge_protocol)
            self._start_rehearsal(cleanup, Campaign(folder / "campaign.toml", machine,
                                                     machine_path, folder / "session.jsonl",
                                                     protocol), sim)
            s.say(f"[yellow]Rehearsal[/] on the built-in simulator (seed {opts.seed}): its "
                  "ports are listed below as if they were your instruments.")

        s.heading("Connect the instruments", "step 1 of 4")
        ports = detect_ports(self.rehearsal.stack.info() if self.rehearsal else None)
        choice: StationChoice = pausable(
            s, "while connecting the instruments",
            lambda: connect_instruments(
                s, ports, protocol.legs, opts.by_eye, opts.indicators,
                (opts.indicators or 6) if opts.simulator else None))
        self.by_eye = set(choice.by_eye)

        s.heading("The machine", "step 2 of 4")
        machine, machine_path = pausable(
            s, "while confirming the machine",
            lambda: self._confirm_machine(machine, machine_path, folder))
        campaign = Campaign(folder / "campaign.toml", machine, machine_path,
                            folder / "session.jsonl", protocol, choice.controller,
                            list(choice.gauges.values()))
        trace = pausable(s, "while recording who and what", lambda: self._questions().ask(
            machine, _indicators(choice, protocol.legs, rehearsal=self.rehearsal is not None),
            datetime.date.today()))
        _apply(campaign, trace, choice.by_eye)
        if _keep_identity(machine_path, folder, machine, trace.machine):
            s.note(f"{shown(machine_path)} now names the machine '{shown(trace.machine.name)}' "
                   f"serial {shown(trace.machine.serial)}: its identity in the history")
        self.session_path = campaign.session
        readings = sum(len(step.gauges) for step in reading_steps(protocol, machine))
        postures = " → ".join(p.title() if isinstance(p, str) else f"{p:g} mm"
                              for p in protocol.postures)
        s.say(f"Plan: legs {', '.join(protocol.legs)}; on each, {postures}, "
              f"{times(protocol.cycles)}: {readings} readings, "
              f"{_how_read(campaign, self.by_eye)}.")
        s.say(f"Everything is saved as it is measured, in {shown(folder)}/.")
        if not pausable(s, "before measuring",
                        lambda: s.confirm("Start? The machine homes, then goes to the Zero "
                                          "posture of the first leg")):
            raise OperatorQuit("the operator did not start the campaign")
        header = {"by_eye": sorted(self.by_eye), "notes": choice.notes,
                  "gauge_range_mm": opts.gauge_range_mm, "max_offset_mm": opts.max_offset_mm}
        return self._measure(campaign, None, header)

    def _continue(self, cleanup: contextlib.ExitStack, path: Path) -> CampaignOutcome:
        """``--resume``: a wizard (or any) session, continued with the wizard."""
        session = load_session(path)
        h = session.header
        if h.plan is None:
            raise InputError(path, "this session has no plan: it was not recorded by a campaign")
        machine = session_machine(session)
        protocol = ProtocolConfig.from_dict(dict(h.plan))
        wizard: dict[str, Any] = dict(h.wizard or {})
        self.options.gauge_range_mm = wizard.get("gauge_range_mm", self.options.gauge_range_mm)
        self.options.max_offset_mm = wizard.get("max_offset_mm", self.options.max_offset_mm)
        self.by_eye = gauges_read_by_eye(session)
        self.session_path = session.path
        campaign_path = Path(h.campaign_file or session.path.with_name("campaign.toml"))
        campaign = Campaign(campaign_path, machine, Path(h.machine_file or ""),
                            session.path, protocol)
        s = self.screen
        s.say("[bold]ogacq wizard[/]: continuing a campaign.")
        s.say(f"{shown(session.path)}: {len(session.readings)} readings recorded.")
        if session.finished:
            if h.simulator is not None:
                # a rehearsal stopped at its result: its simulator again (the same seed,
                # the offsets as before the write), so the write-back and the validation
                # the wizard offers have a controller, as in the rehearsal itself
                self._rehearse_again(cleanup, campaign, h.simulator)
                self.campaign = campaign
            return CampaignOutcome(session.path, identify_session(session), None)
        check_writable(session.path, resuming=True)  # before the operator checks anything
        station = stations(session)[-1]  # the last start's
        if h.simulator is not None:
            self._rehearse_again(cleanup, campaign, h.simulator)
        else:
            c = station.get("controller") or {}
            axes = {a: AxisEndpoint(e.get("port"), e.get("device_id"))
                    for a, e in (c.get("axes") or {}).items()}
            campaign.controller = ControllerSpec(c.get("profile", "cia402"), c.get("port", ""),
                                                 c.get("baudrate"), axes=axes)
            campaign.gauges = [GaugeSpec(k, g["protocol"], g["port"], g.get("channel"),
                                         g.get("unit", "mm"), g.get("serial", ""),
                                         g.get("baudrate"))
                               for k, g in (station.get("gauges") or {}).items()]
        s.heading("Check the instruments", "step 1 of 4")
        pausable(s, "while checking the instruments", lambda: self._recheck(campaign))
        return self._measure(campaign, session, wizard)

    # ====================================================================== helpers
    def _questions(self) -> TraceabilityQuestions:
        """The traceability questions, with the inventory of gauges met before (a
        rehearsal's simulated gauges known too)."""
        if self.questions is None:
            try:
                inventory = load_inventory()
            except InputError as exc:
                self.screen.problem(f"{exc} (the gauges met before are not offered; the "
                                    "file is left as it is)")
                inventory = unreadable_inventory()
            known, hint = [], None
            if self.rehearsal is not None:
                known = [KnownGauge(**g.identity())
                         for g in simulated_gauges(datetime.date.today())]
                hint = self.rehearsal.stack.ambient_c
            self.questions = TraceabilityQuestions(self.screen, inventory, known=known,
                                                   ambient_hint_c=hint)
        return self.questions

    def _end_temperature(self, station: DeviceStation) -> EnvironmentRecord | None:
        """Asked once the last reading is taken, before the result; Ctrl-C there pauses
        and asks again (it went on to the result, the temperature unrecorded)."""
        def ask() -> float | None:
            return self._questions().ask_temperature("Ambient temperature now, at the end, °C")

        with self.gate.immediate():
            try:
                value = pausable(self.screen, "after the last reading, before the result",
                                 ask, self.session_path)
            except InputClosed:
                return None
        if value is None:
            return None
        return EnvironmentRecord(stage="end", ambient_c=value, machine_c=None, source="typed")

    def _start_rehearsal(self, cleanup: contextlib.ExitStack, campaign: Campaign,
                         spec: SimulatorSpec) -> None:
        self.rehearsal = start_rehearsal(campaign, spec)
        cleanup.callback(self.rehearsal.stack.close)
        if self.options.faults:
            self.injector = FaultInjector(self.options.faults, self.rehearsal.stack)
            self.injector.check(0)

    def _rehearse_again(self, cleanup: contextlib.ExitStack, campaign: Campaign,
                        recorded: Mapping[str, Any]) -> None:
        """A rehearsal's session continued: its simulator again, as its station."""
        self._start_rehearsal(cleanup, campaign, SimulatorSpec.from_header(dict(recorded)))
        assert self.rehearsal is not None
        campaign.controller = self.rehearsal.controller
        campaign.gauges = list(self.rehearsal.gauges)

    def _initial_machine(self, folder: Path) -> tuple[MachineSpec | None, Path | None]:
        if self.options.machine is not None:
            return read_machine(self.options.machine), self.options.machine
        if self.options.simulator:
            # the papers' prototype, for a rehearsal without a machine file
            path = write_machine(folder / "machine.toml", PAPER_PROTOTYPE_DIGITAL,
                                 PAPER_PROTOTYPE_DIGITAL_NOTE)
            return read_machine(path), path
        return None, None

    def _confirm_machine(self, machine: MachineSpec | None, path: Path | None, folder: Path,
                         ) -> tuple[MachineSpec, Path]:
        s = self.screen
        while True:
            if machine is None or path is None:
                typed = s.ask("Machine file (TOML: leg_length_mm, rho_min_mm, rho_max_mm, "
                              "gauge_resolution_mm), or 'new' to describe the machine")
                if typed.lower() == "new":
                    machine, path = self._describe_machine(folder)
                    continue
                try:
                    machine, path = read_machine(Path(typed)), Path(typed)
                except InputError as exc:
                    s.problem(str(exc))
                    continue
            s.say(f"Machine file {shown(path)}:")
            s.say(f"  legs {machine.leg_length_mm:g} mm; joints from {machine.rho_min_mm:+g} "
                  f"to {machine.rho_max_mm:+g} mm; gauge resolution "
                  f"{machine.gauge_resolution_mm:g} mm"
                  + (f"; repeatability {machine.gauge_repeatability_mm:g} mm"
                     if machine.gauge_repeatability_mm else ""))
            if self.rehearsal is not None:
                s.note("  (rehearsal: the simulator models this machine)")
            if s.confirm("Is this the machine you are calibrating?"):
                return machine, path
            if self.rehearsal is not None:
                s.say("The simulator models this machine; to rehearse another, start again "
                      "with --machine FILE.")
                continue
            machine = path = None

    def _describe_machine(self, folder: Path) -> tuple[MachineSpec, Path]:
        """The machine file made from the operator's answers, in the campaign's folder;
        the papers' prototype gives the defaults."""
        s = self.screen
        base = PAPER_PROTOTYPE
        while True:
            leg_length_mm = s.ask_parsed("Leg length (mm, the parallelogram's)", _length,
                                         f"{base.leg_length_mm:g}")
            rho_min_mm = s.ask_parsed("Joint travel below the zero posture, for Min "
                                      "(mm, negative)", _travel, f"{base.rho_min_mm:g}")
            rho_max_mm = s.ask_parsed("Joint travel above the zero posture, for Max "
                                      "(mm, positive)", _travel, f"{base.rho_max_mm:g}")
            gauge_resolution_mm = s.ask_parsed(
                "Gauge display step (mm: 0.01 dial, 0.001 digital)", _length,
                f"{base.gauge_resolution_mm:g}")
            try:
                machine = MachineSpec(leg_length_mm, rho_min_mm, rho_max_mm,
                                      gauge_resolution_mm)
            except ValueError as exc:  # the geometry's own checks, in words
                s.problem(str(exc))
                continue
            path = write_machine(folder / "machine.toml", machine,
                                 "described to `ogacq wizard` by the operator")
            return read_machine(path), path

    def _recheck(self, campaign: Campaign) -> None:
        """Before continuing: the controller answers and each gauge gives a value."""
        s = self.screen
        assert campaign.controller is not None
        while True:
            try:
                s.ok(f"controller answers: {check_controller(campaign.controller)}")
                break
            except (DriverError, InputError, ValueError, OSError) as exc:
                s.problem(f"the controller on {campaign.controller.endpoints()} does not answer: "
                          f"{exc}")
                self._retry_or_quit()
        tested: set[tuple[str, str | None]] = set()
        for spec in list(campaign.gauges):
            if spec.gauge in self.by_eye or (spec.port, spec.channel) in tested:
                continue  # an indicator moved leg to leg is tested once
            tested.add((spec.port, spec.channel))
            while True:
                try:
                    s.ok(f"{spec.gauge} reads {test_read(spec):.4f} mm on {spec.port}")
                    break
                except DriverError as exc:
                    s.problem(f"gauge {spec.gauge} on {spec.port} did not give a value: "
                              f"{detail(exc)}")
                    if self._gauge_menu(spec.gauge) != "r":
                        break
        if self.by_eye:
            s.say(f"Read by eye: {', '.join(sorted(self.by_eye))}.")

    def _gauge_menu(self, gauge: str) -> str:
        """After a gauge failed: "r" retry, "m" (now read by eye), or quit."""
        choice = self.screen.choose("What now?", [
            Option("r", "retry (after checking the cable, the power and the battery)"),
            Option("m", f"read {gauge} by eye from now on (give a reason)"),
            Option("q", "quit (the session stays resumable)"),
        ], default="r")
        if choice == "q":
            raise OperatorQuit()
        if choice == "m":
            reason = self.screen.reason(f"read {gauge} by eye")
            self.by_eye.add(gauge)
            self._notes_for_session.append(OperatorRecord(
                action="read_by_eye", details={"gauge": gauge, "reason": reason}))
        return choice

    # ====================================================================== measuring
    def _measure(self, campaign: Campaign, session: LoadedSession | None,
                 wizard_header: dict[str, Any]) -> CampaignOutcome:
        s, opts = self.screen, self.options
        self.campaign = campaign
        session_path = campaign.session
        protocol, machine = campaign.protocol, campaign.machine
        steps = reading_steps(protocol, machine)
        by_id = {step.step: step for step in steps}
        expectations = ReadingExpectations(
            machine, max_offset_mm=opts.max_offset_mm,
            repeat_tolerance_mm=max(0.05, 5 * machine.gauge_resolution_mm),
            gauge_range_mm=opts.gauge_range_mm)
        for r in session.records if session else []:
            if isinstance(r, ReadingRecord) and r.step in by_id:
                expectations.observe(r.gauge.key, by_id[r.step].q_mm, r.reading_mm)
            elif isinstance(r, OperatorRecord) and r.action == "dial_set":
                setting = next(step for step in steps if step.leg == r.details["leg"])
                expectations.set_reference(r.details["gauge"], setting.q_mm,
                                           r.details["value_mm"])
        total = sum(len(step.gauges) for step in steps)
        counter = ReadingCounter(len(session.readings) if session else 0, total)
        handles = RunHandles()
        shown = self.rehearsal.shown_value if self.rehearsal else None

        def pause_here(where: str) -> None:
            handles.note("pause", where=where)
            pause_menu(s, where, session_path)
            handles.note("resume_after_pause")

        ask_reading = ByEyeReadings(s, expectations, protocol.cycles, counter,
                                    machine.gauge_resolution_mm,
                                    lambda: pause_here(f"at reading {counter.done + 1} of "
                                                       f"{counter.total}"), shown)
        setter = LegSetter(s, protocol, steps, machine, handles, self.by_eye, expectations,
                           opts.gauge_range_mm, opts.max_offset_mm, pause_here, shown)
        s.heading("Set the gauges and measure, leg by leg", "step 3 of 4")
        while True:
            if session is not None and session.finished:  # stopped while identifying
                hidden = self.rehearsal.stack.machine.truth.hidden() if self.rehearsal else None
                return CampaignOutcome(session.path, identify_session(session), hidden)
            recorded = session.recorded() if session else set()
            display = CycleProgress(s, steps, protocol, counter, recorded)
            self.gate.on_deferred = display.pausing
            campaign.gauges = [g for g in campaign.gauges if g.gauge not in self.by_eye]
            self._write_campaign_file(campaign)

            def wrap(works: Station, device: DeviceStation, writer: SessionWriter,
                     ) -> GuidedStation:
                station = GuidedStation(works, device, self.gate, expectations=expectations,
                                        by_eye=self.by_eye, ask_reading=ask_reading,
                                        on_pause=lambda: pause_here(
                                            f"after reading {counter.done} of {counter.total}"))
                handles.station = station
                handles.note = lambda action, **fields: writer.write(
                    OperatorRecord(action=action, details=fields))
                for note in self._notes_for_session:
                    writer.write(note)
                self._notes_for_session.clear()
                return station

            s.say("The machine homes and moves: keep clear of it." if session is None
                  else "Reconnecting; the machine homes again, then continues where it "
                       "stopped.")
            try:
                with self.gate.deferred():
                    return run_guided(campaign, wrap=wrap, observer=self._observer(display),
                                      set_gauges=self._asking(setter), resume=session,
                                      wizard_header=wizard_header, rehearsal=self.rehearsal,
                                      environment_at_end=self._end_temperature)
            except OperatorQuit:
                raise
            except CampaignStopped as stop:
                s.stop_live()
                self._after_stop(stop)
            except DriverError as exc:  # before the runner: opening a port, homing
                s.stop_live()
                self._after_failure(exc)
            except KeyboardInterrupt:  # while connecting or homing
                s.stop_live()
                pause_menu(s, "while connecting to the machine",
                           session_path if session_path.exists() else None)
            finally:
                self.gate.on_deferred = lambda: None
                handles.station = None
                handles.note = RunHandles().note  # the run's writer is closed
            session = load_session(session_path) if session_path.exists() else None

    def _asking(self, setter: LegSetter) -> Callable[[SetGauges], None]:
        """The gauge setting asks the technician: Ctrl-C there pauses at once."""
        def set_gauges(step: SetGauges) -> None:
            with self.gate.immediate(), closed_is_quit():
                setter(step)

        return set_gauges

    def _observer(self, display: CycleProgress) -> Callable[[runner.Progress], None]:
        if self.injector is None:
            return display
        injector = self.injector

        def observe(progress: runner.Progress) -> None:
            display(progress)
            injector.observe(progress)

        return observe

    def _write_campaign_file(self, campaign: Campaign) -> None:
        write_atomically(campaign.path, campaign_file_text(campaign, self.by_eye, self.rehearsal)
                         .encode("utf-8"))
        self.resumable_by_ogacq = True  # the schema reads back what it wrote

    def _after_stop(self, stop: CampaignStopped) -> None:
        """Say what stopped the campaign; return to retry, raise OperatorQuit to quit."""
        s = self.screen
        assert self.session_path is not None
        if stop.status == "interrupted":
            s.say(f"[bold yellow]Stopped at once[/] ({shown(stop.reason)}). The axes were stopped; "
                  "every reading so far is saved.")
            self._retry_or_quit("Resume or quit?", "resume where it stopped")
            return
        fault = self._last_fault()
        if fault and fault.during == "read" and fault.gauge:
            gauge = fault.gauge
            s.problem(f"Gauge {describe_gauge(gauge)} stopped answering "
                      f"({self._describe_step(fault.step or '')}):")
            s.say(f"     {shown(fault.message or stop.reason)}")
            s.say("     Check its cable, that it is switched on, and its battery.")
            self._gauge_menu(gauge)
            return
        s.problem(f"The campaign stopped: {stop.reason}")
        s.say("     The axes were stopped and every reading so far is saved. Clear the cause "
              "(an alarm, an obstacle, the emergency stop) before retrying.")
        self._retry_or_quit()

    def _after_failure(self, exc: DriverError) -> None:
        s = self.screen
        match = re.search(r"gauge ([xyz]_[xyz])", str(exc))
        s.problem(f"Could not start: {exc}")
        if match:
            self._gauge_menu(match.group(1))
            return
        s.say("     Check the controller's power and cable, and that no alarm is on.")
        self._retry_or_quit()

    def _retry_or_quit(self, question: str = "What now?", retry: str = "retry") -> None:
        """Return to retry; OperatorQuit to quit."""
        if self.screen.choose(question, [Option("r", retry),
                                         Option("q", "quit (the session stays resumable)")],
                              default="r") == "q":
            raise OperatorQuit() from None

    def _describe_step(self, step_id: str) -> str:
        """``x/c1/p2`` as the technician knows it: x leg, cycle 1, Max posture."""
        if self.campaign is not None:
            for step in reading_steps(self.campaign.protocol, self.campaign.machine):
                if step.step == step_id:
                    return f"{step.leg} leg, cycle {step.cycle}, {step.posture.title()} posture"
        return f"reading {step_id}"

    def _last_fault(self) -> FaultRecord | None:
        assert self.session_path is not None
        faults = load_session(self.session_path).of_type(FaultRecord)
        return faults[-1] if faults else None

    def _say_quit(self) -> None:
        s = self.screen
        s.stop_live()
        path = self.session_path
        if path is None or not path.exists():
            s.say(f"\nStopped. Nothing was measured. Start again with: "
                  f"{shown(self._start_again())}")
            return
        session = load_session(path)
        s.say(f"\nStopped after {len(session.readings)} readings. The session is saved: "
              f"{shown(path)}")
        s.say("Continue it later with:")
        if not self.by_eye and self.resumable_by_ogacq:
            s.say(f"  ogacq resume {shown(path)}            (unattended)")
        s.say(f"  ogacq wizard --resume {shown(path)}   (guided)")

    def _start_again(self) -> str:
        """The command that starts this wizard again, with what chose its machine."""
        opts = self.options
        given = (("--machine", opts.machine), ("--indicators", opts.indicators),
                 ("--out", opts.out))
        return " ".join(["ogacq wizard", *(["--simulator"] if opts.simulator else []),
                         *(f"{flag} {value}" for flag, value in given if value is not None)])


def _indicators(choice: StationChoice, legs: Sequence[str], *, rehearsal: bool = False,
                ) -> list[Indicator]:
    """The physical gauges to identify: one per link (an indicator moved from leg to
    leg serves three gauges), and each dial gauge read by eye. A rehearsal's are the
    simulator's (serial sim-GAUGE)."""
    by_link: dict[tuple[str, str | None], list[GaugeSpec]] = {}
    for spec in choice.gauges.values():
        by_link.setdefault((spec.port, spec.channel), []).append(spec)
    out = []
    for (port, channel), specs in by_link.items():
        where = port + (f" channel {channel}" if channel else "")
        keys = tuple(g.gauge for g in specs)
        label = (f"gauge {keys[0]} ({where})" if len(keys) == 1
                 else f"the indicator on {where} (gauges {', '.join(keys)})")
        out.append(Indicator(label, keys, specs[0].serial
                             or (f"sim-{keys[0]}" if rehearsal else "")))
    out += [Indicator(f"dial gauge {key}", (key,))
            for key in gauges_of(legs) if key in choice.by_eye]
    return out


def _keep_identity(path: Path, folder: Path, read: MachineSpec, answered: MachineSpec,
                   ) -> bool:
    """The name and serial the operator answered, into the machine file the wizard
    wrote in its own folder (a rehearsal's, or one described by answering questions),
    so that a later campaign of that file is the same machine in the history (issue
    38.1); a machine file the operator named is theirs, never rewritten. Whether it
    was written."""
    own = path.resolve() == (folder / "machine.toml").resolve()
    if not own or not answered.serial or (answered.name, answered.serial) == (read.name,
                                                                              read.serial):
        return False
    write_machine(path, answered, "written by `ogacq wizard`: the machine as described, its "
                                  "name and serial as the operator answered")
    return True


def _apply(campaign: Campaign, trace: Traceability, by_eye: set[str]) -> None:
    """The answers, into the campaign: the session header and the gate read them."""
    campaign.machine = trace.machine
    campaign.operator = trace.operator
    if trace.ambient_start_c is not None:
        campaign.environment = EnvironmentSpec(ambient_c=trace.ambient_start_c)
    campaign.gauges = [replace(g, **trace.identities.get(g.gauge, {}))
                       for g in campaign.gauges]
    campaign.extra_instruments = [i for i in trace.instruments() if i.gauge in by_eye]
    campaign.override_expired = trace.override_expired


def _how_read(campaign: Campaign, by_eye: set[str]) -> str:
    """How the plan's readings are taken: by the gauges, typed, or both."""
    if not by_eye:
        return "taken automatically"
    if not campaign.gauges:  # none is read over a link
        return "each typed by you from the dial"
    return f"typed by you for {', '.join(sorted(by_eye))}, the others taken automatically"


def _length(text: str) -> float:
    value = typed_number(text.strip().removesuffix("mm"), "a length in mm (for example 310.25)")
    if not value > 0:
        raise ValueError(f"a positive length in mm, got {text}")
    return value


def _travel(text: str) -> float:
    return typed_number(text.strip().removesuffix("mm"), "a travel in mm (for example -100)")


@dataclass(frozen=True)
class NewFolder:
    """A new campaign's folder, and whether the wizard made it."""

    path: Path
    made: bool

    @classmethod
    def make(cls, out: Path | None) -> NewFolder:
        folder = out or Path(f"ogacq-wizard-{time.strftime('%Y%m%d-%H%M%S')}")
        if folder.exists() and any(folder.iterdir()):
            raise InputError(folder, "exists and is not empty: choose another --out folder")
        existed = folder.exists()
        folder.mkdir(parents=True, exist_ok=True)
        return cls(folder, not existed)

    def remove(self) -> None:
        """The files the wizard writes before a session (the rehearsal's machine, the
        campaign file), and the folder if the wizard made it and nothing else is there."""
        for name in ("machine.toml", "campaign.toml"):
            with contextlib.suppress(OSError):
                (self.path / name).unlink()
        if self.made:
            with contextlib.suppress(OSError):  # not empty: someone else's files stay
                self.path.rmdir()
