"""Terminal rendering: the only place that imports rich."""

from __future__ import annotations

import sys
from collections.abc import Callable, Iterator, Mapping
from contextlib import contextmanager
from typing import TYPE_CHECKING, Any

from ogacq.cli.plain import Printer, bar_of, shown, table_of
from ogacq.cli.plain import console as new_console
from ogacq.cli.render_fit import format_number
from ogacq.cli.verdict_text import paragraph
from ogacq.model.parameters import effect_of
from ogacq.record.calibration_record import CalibrationRecord
from ogacq.uncertainty.reporting import expanded_mm, result_headline, rounded, two_digits

if TYPE_CHECKING:  # start-up: refit and diagnose load neither the bar nor the records
    from pathlib import Path

    from rich.progress import Progress

    from ogacq.campaign.run import CampaignOutcome
    from ogacq.diagnose.diagnosis import Diagnosis
    from ogacq.identify.accuracy import AccuracyPrediction
    from ogacq.protocol.runner import Observer
    from ogacq.protocol.runner import Progress as RunnerProgress
    from ogacq.session.state import Completeness
    from ogacq.session.store import LoadedSession

console = new_console()


def print_plan(pred: AccuracyPrediction, machine_name: str, postures: str, cycles: int,
               noise: str) -> None:
    """``noise``: the gauge noise predicted with and where it came from, in words."""
    console.print(f"[bold]{shown(machine_name)}[/]: {shown(postures)}, {cycles} cycles per leg, "
                  f"{pred.n_readings} readings; {shown(noise)}")
    monte_carlo = [f">std Monte-Carlo ({pred.trials} fits)", ">bias"]
    table = table_of("parameter", ">std analytic",
                     *(monte_carlo if pred.mc_std is not None else []), "unit")
    for k, name in enumerate(pred.names):
        row = [name, f"{pred.analytic_std[k]:.4f}"]
        if pred.mc_std is not None and pred.mc_bias is not None:
            row += [f"{pred.mc_std[k]:.4f}", f"{pred.mc_bias[k]:+.4f}"]
        table.add_row(*row, effect_of(name).unit)
    console.print(table)
    ident = pred.identifiability
    if ident.identifiable:
        console.print(f"[green]identifiable[/] (condition number {ident.condition_number:.3g})")
    else:
        console.print("[red]not identifiable[/] with this plan:")
        for reason in ident.reasons:
            console.print(f"  - {shown(reason)}")
    if pred.mc_std is not None:
        console.print(f"Monte-Carlo: {pred.converged_fraction:.1%} of fits converged, "
                      f"{pred.mc_seconds:.2f} s")
        if pred.ran_off_fraction:
            from ogacq.identify.accuracy import RAN_OFF_RANGES
            console.print(f"  {pred.ran_off_fraction:.1%} ran off beyond {RAN_OFF_RANGES:g} "
                          "times a parameter's plausible range (a direction these readings "
                          "do not bound): left out of the std and bias")


def print_sim(info: dict, campaign: Path | None = None) -> None:
    m = info["modbus"]
    where = f"{m['host']}:{m['port']}" if m["transport"] == "tcp" else m["port"]
    console.print(f"[bold]simulated controller[/] ({shown(m['profile'])}, Modbus "
                  f"{shown(m['transport'].upper())}): {shown(where)}, device ids "
                  f"{shown(m['device_ids'])}")
    for axis, a in info.get("modbus_axes", {}).items():  # one endpoint per axis
        at = f"{a['host']}:{a['port']}" if a["transport"] == "tcp" else a["port"]
        console.print(f"  axis {shown(axis)}: {shown(at)}, device id "
                      f"{shown(a['device_ids'][axis])}")
    table = table_of("gauge", "port", "protocol")
    for key, g in info["gauges"].items():
        table.add_row(shown(key), shown(g["port"]), shown(g["protocol"]))
    for axis, g in info.get("axis_scales", {}).items():  # each scale on a line of its own
        table.add_row(f"{shown(axis)} axis scale", shown(g["port"]), shown(g["protocol"]))
    console.print(table)
    if campaign is not None:  # what the file is for, while this simulator serves
        scaled = "".join(f" (or ogacq positioning {shown(campaign)} --axis {shown(axis)})"
                         for axis in list(info.get("axis_scales", {}))[:1])
        console.print(f"running; Ctrl-C to stop. next, in another terminal: ogacq run "
                      f"{shown(campaign)}{scaled}")
    else:
        console.print("running; Ctrl-C to stop")


class CampaignProgress:
    """The runner's observer as the command line shows it; ``paused()`` lifts a live
    bar off the terminal while the operator is asked something."""

    def __init__(self, show: Observer = lambda progress: None,
                 bar: Progress | None = None) -> None:
        self._show = show
        self._bar = bar

    def __call__(self, progress: RunnerProgress) -> None:
        self._show(progress)

    @contextmanager
    def paused(self) -> Iterator[None]:
        if self._bar is None:
            yield
            return
        self._bar.stop()
        try:
            yield
        finally:
            self._bar.start()


@contextmanager
def trials_progress(label: str) -> Iterator[Callable[[int, int], None] | None]:
    """A callback ``(done, total)`` showing a bar on the terminal (stderr, so that a
    --json on stdout stays clean), and nothing when no one watches."""
    err = new_console(stderr=True)
    if not err.is_terminal:
        yield None
        return
    with bar_of(label, console=err, transient=True) as bar:
        task = bar.add_task(label, total=None)
        yield lambda done, total: bar.update(task, completed=done, total=total)


@contextmanager
def working(what: str) -> Iterator[None]:
    """A step of some seconds said while it runs: a spinner with its elapsed time on a
    terminal (stderr: stdout stays the command's output), nothing to a pipe or a log."""
    err = new_console(stderr=True)
    if not err.is_terminal:
        yield
        return
    with err.status(f"{shown(what)}…"):
        yield


@contextmanager
def campaign_progress(enabled: bool = True) -> Iterator[CampaignProgress]:
    """An observer for the runner: a live bar on a terminal, log lines otherwise."""
    if not enabled:
        yield CampaignProgress()
        return
    if not sys.stdout.isatty():
        err = new_console(stderr=True)

        def log_line(progress: RunnerProgress) -> None:
            err.print(f"\\[{progress.done}/{progress.total}] {shown(progress.message)}")

        yield CampaignProgress(log_line)
        return
    with bar_of("{task.description}", console=console, transient=False, last=True) as bar:
        task = bar.add_task("readings", total=None, last="")

        def update(progress: RunnerProgress) -> None:
            bar.update(task, completed=progress.done, total=progress.total,
                       last=shown(progress.message))

        yield CampaignProgress(update, bar)


def print_outcome(outcome: CampaignOutcome, record: Mapping[str, Any]) -> None:
    """The identified offsets as a person reads them: each with its expanded
    uncertainty U (k stated, GUM 7.2.6), from the campaign's ``record``; the
    simulator's truth beside them in a rehearsal."""
    result = outcome.fit
    results = CalibrationRecord.from_json(record).results or {}
    table = table_of("parameter", ">identified", ">U", ">k",
                     *([">hidden truth", ">error"] if outcome.hidden is not None else []), "unit",
                     title=f"identified joint offsets ({len(result.observations)} readings)")
    incomplete = False
    for name, value in zip(result.names, result.values, strict=True):
        line = result_headline(results, name, float(value), effect_of(name).unit)
        incomplete |= not line.complete
        row = [name, line.value, line.U or "not evaluated",
               f"{line.k:g}" if line.k is not None else "-"]
        if outcome.hidden is not None:
            truth, U = outcome.hidden.get(name, 0.0), expanded_mm(results, name)
            row += [rounded(truth, U, sign=True), rounded(float(value) - truth, U, sign=True)]
        table.add_row(*row, line.unit)
    console.print(table)
    console.print("U: the expanded uncertainty of the record's budget (k = 2: about 95 %)"
                  + ("; [yellow]budget incomplete: U leaves out what was not recorded "
                     "(see the record's budget)[/]" if incomplete else ""))
    # in the noise's unit: one unit on the line
    console.print(f"residual rms {result.residual_rms_mm:.2g} mm, gauge noise "
                  f"{result.noise.describe()}; session {shown(outcome.session_path)}")
    if outcome.simulated:
        # the built-in one or `ogacq sim`'s, whose drives say so (issue 38.2)
        console.print("[bold reverse] SIMULATED [/] a rehearsal on a simulator: "
                      "not a calibration of the machine")


def print_end(lines: list[str]) -> None:
    """The end of a campaign: the verdict, the record id, the next commands."""
    now = Printer()  # at this moment's width
    now.print()
    for line in lines:
        now.print(shown(line))  # wrapped between words


def _print_context(session: LoadedSession) -> None:
    """Who, when, with which certificates and at what temperature (what is known)."""
    from ogacq.record.context import calibration_context

    c = calibration_context(session)
    date = c.date.isoformat(sep=" ") if c.date else "not recorded"
    console.print(f"machine {shown(c.machine_name or '(no name)')}, serial "
                  f"{shown(c.machine_serial or 'not recorded')}; operator "
                  f"{shown(c.operator or 'not recorded')}; date {shown(date)}"
                  + (" (rehearsed on the simulator)" if c.simulated_date else ""))
    for i in c.instruments:
        if i.certificate or i.due:
            state = {True: "EXPIRED", False: "valid", None: "?"}[c.expired(i)]
            console.print(f"  gauge {shown(i.label)}: certificate {shown(i.certificate or '?')}"
                          f", due {shown(i.due or '?')} ({state})")
    env = c.environment
    if env.start or env.end:
        words = [f"{stage} {t.ambient_c if t.ambient_c is not None else '?'} °C ambient"
                 + (f", {t.machine_c} °C machine" if t.machine_c is not None else "")
                 + f" ({t.source})" for stage, t in (("start", env.start), ("end", env.end))
                 if t is not None]
        console.print("temperature: " + shown("; ".join(words)))
    for o in c.overrides:
        console.print(f"override ({shown(o.what)}) {shown(o.subject)}: {shown(o.reason)}")


def print_session(session: LoadedSession, state: Completeness | None = None) -> None:
    """What ``session`` holds; ``state``: its completeness (ogacq.session.state)."""
    from ogacq.session.records import (
        EndRecord,
        FaultRecord,
        MoveRecord,
        ReferenceRecord,
        ResumeRecord,
    )

    header = session.header
    ends = session.of_type(EndRecord)
    status = ends[-1].status if ends else "in progress or killed"
    console.print(f"[bold]{shown(session.path)}[/]: {shown(header.software or '?')}, "
                  f"created {shown(header.created or '?')}, status [bold]{shown(status)}[/]")
    if state is not None and not state.complete:
        console.print(f"[yellow]{shown(state.describe())}[/]")
    for note in session.integrity.notes():
        console.print(f"[yellow]{shown(note)}[/]")
    machine = header.machine or {}
    console.print(f"machine: L = {shown(machine.get('leg_length_mm'))} mm, postures "
                  f"{shown(machine.get('rho_min_mm'))}..{shown(machine.get('rho_max_mm'))} mm, "
                  f"gauges {shown(machine.get('gauge_resolution_mm'))} mm")
    _print_context(session)
    station = header.station or {}
    controller = station.get("controller")
    if isinstance(controller, dict):
        console.print(f"controller: {shown(controller.get('profile'))} at "
                      f"{shown(controller.get('port'))}"
                      + (" (simulated)" if station.get("simulated") else ""))
    faults = session.of_type(FaultRecord)
    console.print(f"readings: {len(session.readings)}, moves: "
                  f"{len(session.of_type(MoveRecord))}, faults: {len(faults)}, resumed: "
                  f"{len(session.of_type(ResumeRecord))} times")
    for fault in faults[-3:]:
        console.print(f"  fault during {shown(fault.during)}: {shown(fault.message)}")
    for ref in session.of_type(ReferenceRecord):  # after a loss of a drive: the reference
        said = f"  reference {ref.event}" + (f" ({ref.cause})" if ref.cause else "")
        if ref.differences_mm:
            worst = max(abs(d) for d in ref.differences_mm.values())
            said += (f" at {ref.step}: {worst:.4f} mm at most, within {ref.tolerance_mm} mm "
                     "expected")
        elif ref.message:
            said += f": {ref.message}"
        console.print(said, markup=False)
    if ends and ends[-1].reason:
        console.print(f"stopped because: {shown(ends[-1].reason)}")
    if session.result is not None:
        refit = session.result.refit
        for name, where in refit["parameters"].items():
            for axis, value in where.items():
                std = refit.get("std", {}).get(name, {}).get(axis)
                # a look at what the session holds: its fit's std, named so (the
                # headline U is the record's, `ogacq report`)
                console.print(f"  {shown(name)}.{shown(axis)} = {format_number(value)} mm (fit std "
                              f"{two_digits(std)} mm)")


def print_demo_diagnosis(d: Diagnosis, hidden: dict[str, float]) -> None:
    """The diagnosis verdict and what it found, beside the simulator's hidden effects."""
    diagnosis = d.to_json()
    if d.outcome == "consistent":
        console.print(f"diagnosis: the joint offsets explain the readings, "
                      f"{paragraph(d.base)}: nothing left out")
        return
    console.print(f"[yellow]diagnosis: the joint offsets alone: {paragraph(d.base)}[/]")
    table = table_of("effect", ">found", ">std", ">hidden truth", "unit", "alternatives",
                     title="physics found by the diagnosis")
    found = set()
    for e in diagnosis["effects"]:
        name = f"{e['effect']}.{e['where']}"
        found.add(name)
        if e["effect"] == "unexplained":
            table.add_row(f"unexplained at {e['where']}", "-", "-", "-", "", "")
            continue
        alternatives = ", ".join(f"{a['effect']}.{a['where']}" for a in e["alternatives"])
        # one face for one quantity: the value and the truth at the std's decimal place,
        # the std to two digits, as every later line says it (it was "+382.6237 |
        # 23.8388" here, then "+383 ± 24 ppm"; JCGM 100:2008 7.2.6)
        truth = hidden.get(name)
        table.add_row(name, rounded(e["value"], e["std"], sign=True), two_digits(e["std"]),
                      rounded(truth, e["std"], sign=True), e["unit"], alternatives)
    for name, value in hidden.items():
        if not name.startswith("joint_offset.") and name not in found:
            table.add_row(name, "not found", "", format_number(value), effect_of(name).unit,
                          "")
    console.print(table)
    console.print(f"with these effects the fit is {paragraph(d.final)}")
    offsets = diagnosis["parameters"]["joint_offset"]
    console.print("joint offsets of the final model: " + ", ".join(
        f"{a} {offsets[a]:+.4f} (truth {hidden.get(f'joint_offset.{a}', 0.0):+.4f})"
        for a in "xyz") + " mm")
