"""Rendering for ``ogacq history``: the calibrations of a machine with their drift
flags, its offsets states, and the same as JSON."""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from typing import Any

from rich.console import Console
from rich.table import Table

from ogacq.cli.plain import console as new_console
from ogacq.cli.plain import shown, table_of
from ogacq.history.drift import ControllerChange, Drift, expanded
from ogacq.history.entries import Calibration, Event, Machine, OffsetState, parameter_unit
from ogacq.history.states import MachineState
from ogacq.model.units import UM_PER_MM
from ogacq.uncertainty.reporting import rounded, two_digits

DRIFT_MARK = "!"  # beside a value whose change from the previous calibration exceeds U
# record id -> parameter -> the change the record's write-backs made
Written = Mapping[str, Mapping[str, float]]


def verdict_words(verdict: dict[str, Any] | None) -> str:
    if not isinstance(verdict, dict):
        return "-"
    state = verdict.get("state")
    if state == "unjudged" or verdict.get("consistent") is None:
        return "cannot be judged"
    return "within noise" if verdict.get("consistent") else "NOT within noise"


def acceptance_words(calibration: Calibration) -> str:
    acceptance = calibration.acceptance if isinstance(calibration.acceptance, dict) else {}
    found = calibration.acceptance_decision or "-"
    left = (acceptance.get("as_left") or {}).get("decision")
    return found if left in (None, "not evaluated") else f"{found} / left {left}"


def _value(calibration: Calibration, name: str, flagged: bool) -> str:
    p = calibration.parameters.get(name)
    if p is None:
        return "-"
    u, basis = expanded(p)
    # one rounding rule: the value at its U's decimal place, U to two digits
    spread = "" if u is None else (f" ± {two_digits(u)}" + ("" if basis == "U" else "*"))
    return rounded(p.value_mm, u, sign=True) + spread + (f" {DRIFT_MARK}" if flagged else "")


def _when(date: str | None) -> str:
    """An ISO date-time to the minute: seconds and zone add nothing to a history."""
    return "-" if not date else date.replace("T", " ")[:16]


def _short(name: str) -> str:
    return name.removeprefix("joint_offset.")


def _ambient(calibration: Calibration) -> str:
    t = calibration.ambient_c
    return f"{t:.1f} °C" if t is not None and math.isfinite(t) else "-"


def _plural(n: int, word: str) -> str:
    return f"{n} {word}{'s' if n != 1 else ''}"


def _print_who(console: Console, machine: Machine, where: str,
               calibrations: Sequence[Calibration]) -> None:
    """Who calibrated and how it came out, a row per calibration; where the table does
    not fit whole (a long operator, a SIMULATED mark), a block per calibration instead
    of a column cut off."""
    console.print(f"{shown(machine.describe())}: "
                  f"{_plural(len(calibrations), 'calibration')} in {shown(where)}")
    rows = [(shown(_when(c.date)), shown(c.record_id) + (" SIMULATED" if c.simulated else ""),
             shown(c.operator or "-"), shown(verdict_words(c.verdict)),
             shown(acceptance_words(c)), _ambient(c))
            for c in calibrations]
    table = Table(show_edge=False, header_style="bold")
    for column in ("date", "record", "operator", "fit", "acceptance", "ambient"):
        table.add_column(column, no_wrap=column in ("date", "record"), min_width=len(column),
                         justify="right" if column == "ambient" else "left")
    for row in rows:
        table.add_row(*row)
    if _printed_whole(console, table):
        return
    for date, record, operator, fit, acceptance, ambient in rows:
        console.print(f"{date}  {record}\n    operator {operator}; fit {fit}; acceptance "
                      f"{acceptance}; ambient {ambient}")


def _who_notes(calibrations: Sequence[Calibration], written: Written,
               events: Sequence[Event] = ()) -> list[str]:
    """Which campaign validates which write-back, and what biases its offsets listed
    alone; whether any is a rehearsal."""
    left = _left_on_machine(events)
    notes = [f"{after.record_id} validates the write-back made from {before.record_id}"
             + _biased(before, after, left.get(before.record_id, []))
             for before, after in zip(calibrations, calibrations[1:], strict=False)
             if written.get(before.record_id)]  # the first campaign after a write-back
    if any(c.simulated for c in calibrations):
        notes.append("SIMULATED: a rehearsal on a simulator, not a calibration of the "
                     "machine, nor compared with one for drift")
    return notes


def _left_on_machine(events: Sequence[Event]) -> dict[str, list[str]]:
    """record id -> the effects its diagnosis explained the readings with (the
    diagnosis's JSON, INTERCHANGE.md: ``final.consistent``, ``effects``): a write-back
    corrects the joint offsets only, so they stay on the machine."""
    out = {}
    for e in events:
        found = e.details or {}
        effects = [f"{x.get('effect')}.{x.get('where')}" for x in found.get("effects") or []
                   if isinstance(x, dict) and x.get("effect") != "unexplained"]
        if e.kind == "diagnosis" and (found.get("final") or {}).get("consistent") and effects:
            out[e.record_id] = effects
    return out


def _biased(before: Calibration, after: Calibration, effects: Sequence[str]) -> str:
    """Why the validation's joint offsets listed here are not what the write-back left,
    where the calibration's diagnosis found effects beside them (issue 38.4: a
    squareness gave -0.025/-0.031/+0.023 mm, a write-back that looked failed)."""
    if not effects:
        return ""
    judged = (f"`ogacq report {before.session_path} --after {after.session_path}` judges "
              "it with them carried over" if before.session_path and after.session_path
              else "its record judges it with them carried over")
    return (f": its joint offsets below are fitted alone, biased by {', '.join(effects)}, "
            f"which the diagnosis of {before.record_id} found and a write-back leaves on "
            f"the machine; {judged}")


def _values_table(calibrations: Sequence[Calibration], drifts: Sequence[Drift],
                  written: Written) -> Table:
    """The identified values, a row per calibration and one per write-back after it."""
    names = list(dict.fromkeys(n for c in calibrations for n in c.parameters))
    flagged = {(d.to_record, d.parameter) for d in drifts if d.flagged}
    joint = all(n.startswith("joint_offset.") for n in names)
    # one unit per quantity, as the figure (--plot) draws it: the title's mm when every
    # column is a length, else each column's own unit in its header
    units = {n: parameter_unit(n) for n in names}
    in_mm = all(u == "mm" for u in units.values())
    values = Table(title=f"identified {'joint offsets ' if joint else ''}"
                         f"({'mm ± U' if in_mm else 'value ± U'}, k = 2; "
                         f"{DRIFT_MARK} changed by more than U)",
                   show_edge=False, header_style="bold", title_justify="left")
    values.add_column("date")  # wraps before its time, never a value cut off
    for name in names:
        header = _short(name) if in_mm else f"{_short(name)} ({units[name]})"
        values.add_column(shown(header), justify="right", no_wrap=True)
    for c in calibrations:
        values.add_row(shown(_when(c.date)), *(_value(c, n, (c.record_id, n) in flagged)
                                               for n in names))
        wrote = written.get(c.record_id)
        if wrote and c is not calibrations[-1]:
            values.add_row("  written back", *(f"{wrote[n]:+.4f}" if n in wrote else ""
                                               for n in names), style="italic")
    return values


def _drift_notes(calibrations: Sequence[Calibration], drifts: Sequence[Drift],
                 written: Written) -> list[str]:
    """The footnote on U, each change flagged, or that none is."""
    notes = []
    if any(p.expanded_mm is None for c in calibrations for p in c.parameters.values()):
        notes.append("* U unknown (no uncertainty budget): 2 x the fit's std shown and used")
    flagged = [d for d in drifts if d.flagged]
    notes += [f"[red]{DRIFT_MARK} {shown(d.describe())}[/]" for d in flagged]
    if len(calibrations) > 1 and not flagged:
        between = any(written.get(c.record_id) for c in calibrations[:-1])
        by_force = any(d.controller_moved_mm is not None for d in drifts)
        notes.append("no change between successive calibrations exceeds its U"
                     + (" (each judged from the offsets the controller held during the "
                        "campaigns)" if by_force else
                        " (each judged from the state as left by the write-backs between)"
                        if between else ""))
    return notes


def _events_note(machine: Machine, events: Sequence[Event]) -> str | None:
    """The other events recorded, counted by kind."""
    kinds = [e.kind for e in events if e.kind != "calibration"]
    if not kinds:
        return None
    counts = {k: kinds.count(k) for k in dict.fromkeys(kinds)}
    hint = (f" (`ogacq history {machine.label!r} --states`: the offsets written)"
            if "write-back" in counts or "restore" in counts else "")
    return "also recorded: " + ", ".join(f"{n} {k}{'s' if n > 1 else ''}"
                                         for k, n in counts.items()) + hint


def print_calibrations(machine: Machine, where: str, calibrations: Sequence[Calibration],
                       drifts: Sequence[Drift], events: Sequence[Event],
                       written: Written | None = None,
                       controller_moves: Sequence[ControllerChange] = ()) -> None:
    """The calibrations, their values with the write-backs between them (``written``:
    record id -> parameter -> the change the record's write-backs made), each change
    judged from the state as left."""
    console = new_console()  # per call: the terminal's width as it is now
    written = written or {}
    # two tables, so each fits a terminal of 80 columns: who and how, then the values
    _print_who(console, machine, where, calibrations)
    for line in _who_notes(calibrations, written, events):
        console.print(shown(line))
    console.print(_values_table(calibrations, drifts, written))
    for line in _drift_notes(calibrations, drifts, written):
        console.print(line)
    for move in controller_moves:
        console.print(f"[yellow]{shown(move.describe())}[/]")
    events_note = _events_note(machine, events)
    if events_note:
        console.print(shown(events_note))


def _printed_whole(console: Console, table: Table) -> bool:
    """``table`` printed when it fits the terminal whole (whether it did): rich would
    otherwise squeeze its columns, down to nothing for some (a value lost, not wrapped)."""
    natural = console.measure(table, options=console.options.update_width(10_000)).maximum
    if natural <= console.width:
        console.print(table)
    return natural <= console.width


def _print_rows(console: Console, title: str, columns: Sequence[str],
                rows: Sequence[Sequence[str]], rest: Callable[[Sequence[str]], str]) -> None:
    """A table of text cells (already ``shown``), or where it does not fit the
    terminal, a block per row: its first three cells on a line, ``rest`` of the row
    in words below them."""
    table = Table(title=title, show_edge=False, header_style="bold", title_justify="left")
    for column in columns:
        table.add_column(column, justify="right" if column in ("x", "y", "z") else "left",
                         no_wrap=column in ("state", "when", "record"))
    for row in rows:
        table.add_row(*row)
    if _printed_whole(console, table):
        return
    console.print(title)
    for row in rows:
        console.print("  ".join(row[:3]) + "\n    " + rest(row))


def _print_offsets_states(console: Console, machine: Machine, where: str,
                          states: Sequence[OffsetState], current: OffsetState | None,
                          machine_states: Sequence[MachineState]) -> None:
    """Each offsets state: which write-back or restore left it, and what became of it."""
    fate = {v.state_id: v.fate for v in machine_states if v.fate}
    in_force = current.state_id if current is not None else None
    rows = []
    for v in states:
        mark = ", in force" if v.state_id == in_force else ""
        told = f"; {fate[v.state_id]}" if v.state_id in fate else ""
        rows.append([shown(v.state_id), shown(v.at or "-"), shown(v.record_id),
                     shown(f"{'before' if v.stage == 'before' else 'after'} {v.action} "
                           f"{v.operation}"),
                     *(f"{v.offsets_mm[a]:+.4f}" if v.offsets_mm[a] is not None else "-"
                       for a in "xyz"), shown(v.status + mark + told)])
    _print_rows(console, f"{shown(machine.describe())}: offsets states in {shown(where)} "
                         "(o, mm)",
                ("state", "when", "record", "what", "x", "y", "z", "status"), rows,
                lambda r: f"{r[3]}: x {r[4]}, y {r[5]}, z {r[6]} mm; {r[7]}")


def _print_maps_states(console: Console, machine: Machine,
                       maps: Sequence[MachineState]) -> None:
    """Each maps state: the error maps ogacq applies, by checksum."""
    rows = [[shown(m.state_id), shown(m.at or "-"), shown(m.record_id),
             shown(f"{m.stage} {m.action} {m.operation}"),
             shown(", ".join(sorted(m.maps or {})) or "none"),
             shown((m.maps_checksum or "-")[:12]),
             shown(m.status + (f"; {m.fate}" if m.fate else ""))] for m in maps]
    _print_rows(console, f"{shown(machine.describe())}: maps states (the error maps ogacq "
                         "applies)",
                ("state", "when", "record", "what", "axes", "checksum", "status"), rows,
                lambda r: f"{r[3]}: axes {r[4]}, checksum {r[5]}; {r[6]}")


def print_states(machine: Machine, where: str, states: Sequence[OffsetState],
                 current: OffsetState | None,
                 machine_states: Sequence[MachineState] = ()) -> None:
    console = new_console()  # per call: the terminal's width as it is now
    _print_offsets_states(console, machine, where, states, current, machine_states)
    maps = [v for v in machine_states if v.kind == "maps"]
    if maps:
        _print_maps_states(console, machine, maps)
    if machine_states:
        console.print(f"compare two: ogacq history {machine.label!r} --states --diff STATE "
                      "STATE")
    if not states:
        console.print("no write-back of this machine is recorded")
    else:
        console.print(f"go back to one: ogacq offsets restore --machine "
                      f"{shown(repr(machine.label))} --to STATE (a state above, or a "
                      "calibration's record id)")


def calibrations_json(machine: Machine, calibrations: Sequence[Calibration],
                      drifts: Sequence[Drift],
                      controller_moves: Sequence[ControllerChange] = ()) -> dict[str, Any]:
    by_target: dict[str, dict[str, Any]] = {}
    for d in drifts:
        by_target.setdefault(d.to_record, {})[d.parameter] = d.to_json()
    return {
        "machine": {"name": machine.name, "serial": machine.serial},
        "calibrations": [{
            "record": c.record_id, "date": c.date, "operator": c.operator,
            "simulated": c.simulated,
            "parameters": {n: {"value_mm": p.value_mm, "u_mm": p.u_mm, "U_mm": p.expanded_mm,
                               "k": p.k, "std_mm": p.std_mm}
                           for n, p in c.parameters.items()},
            "verdict": c.verdict,
            "acceptance": {"as_found": c.acceptance_decision,
                           "as_left": ((c.acceptance or {}).get("as_left") or {}).get(
                               "decision") if isinstance(c.acceptance, dict) else None},
            "ambient_c": c.ambient_c,
            "instruments": c.instruments, "overrides": c.overrides,
            "session": {"path": c.session_path, "sha256": c.session_sha256},
            "changes": by_target.get(c.record_id, {})} for c in calibrations],
        "drifts": [d.to_json() for d in drifts if d.flagged],
        "controller_changes": [m.to_json() for m in controller_moves],
    }


def states_json(machine: Machine, states: Sequence[OffsetState],
                current: OffsetState | None,
                machine_states: Sequence[MachineState] = ()) -> dict[str, Any]:
    return {"machine": {"name": machine.name, "serial": machine.serial},
            "states": [v.as_mapping() for v in states],
            "in_force": current.state_id if current is not None else None,
            "machine_states": [v.as_mapping() for v in machine_states]}


def print_diff(machine: Machine, compared: dict[str, Any]) -> None:
    console = new_console()
    a, b = compared["from"], compared["to"]
    console.print(f"{shown(machine.describe())}: from {a['state']} ({a['at'] or 'undated'}, "
                  f"{a['stage']} {a['action']} {a['operation']}) to {b['state']} "
                  f"({b['at'] or 'undated'}, {b['stage']} {b['action']} {b['operation']})")
    table = table_of("axis", ">offset from", ">offset to", ">change", "map")
    for axis, o in compared["offsets_mm"].items():
        m = compared["maps"][axis]
        if m["change"] == "none":
            words = "unchanged" if m.get("from") else "none"
        else:
            words = (f"{m['change']} ({m.get('from') or '-'} -> {m.get('to') or '-'}): up to "
                     f"{m['max_forward_change_mm'] * UM_PER_MM:.2f} µm forward, "
                     f"{m['max_reverse_change_mm'] * UM_PER_MM:.2f} µm reverse")
        table.add_row(axis, *(f"{v:+.4f}" if v is not None else "-"
                              for v in (o["from"], o["to"], o["change"])), words)
    console.print(table)
    if not compared["maps_known"]:
        console.print("no maps state is recorded at or before these states")
