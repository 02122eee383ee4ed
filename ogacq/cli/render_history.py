"""Rendering for ``ogacq history``: the calibrations of a machine with their drift
flags, its offsets states, and the same as JSON."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

from rich.table import Table

from ogacq.cli.plain import console as new_console
from ogacq.cli.plain import shown
from ogacq.history.drift import Drift, expanded
from ogacq.history.states import MachineState
from ogacq.history.store import Calibration, Event, Machine, OffsetState

DRIFT_MARK = "!"  # beside a value whose change from the previous calibration exceeds U


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
    spread = "" if u is None else (f" ± {u:.4f}" + ("" if basis == "U" else "*"))
    return f"{p.value_mm:+.4f}{spread}" + (f" {DRIFT_MARK}" if flagged else "")


def _when(date: str | None) -> str:
    """An ISO date-time to the minute: seconds and zone add nothing to a history."""
    return "-" if not date else date.replace("T", " ")[:16]


def _short(name: str) -> str:
    return name.removeprefix("joint_offset.") if name.startswith("joint_offset.") else name


def print_calibrations(machine: Machine, where: str, calibrations: Sequence[Calibration],
                       drifts: Sequence[Drift], events: Sequence[Event],
                       written: Mapping[str, Mapping[str, float]] | None = None) -> None:
    """The calibrations, their values with the write-backs between them (``written``:
    record id -> parameter -> the change the record's write-backs made), each change
    judged from the state as left."""
    console = new_console()  # per call: the terminal's width as it is now
    written = written or {}
    names = list(dict.fromkeys(n for c in calibrations for n in c.parameters))
    flagged = {(d.to_record, d.parameter) for d in drifts if d.flagged}
    joint = all(n.startswith("joint_offset.") for n in names)
    # Two tables, so each fits a terminal of 80 columns: who and how, then the values.
    table = Table(title=f"{shown(machine.describe())}: {len(calibrations)} calibration"
                        f"{'s' if len(calibrations) != 1 else ''} in {shown(where)}",
                  show_edge=False, header_style="bold", title_justify="left")
    for column in ("date", "record", "operator", "fit", "acceptance", "ambient"):
        table.add_column(column, no_wrap=column in ("date", "record"), min_width=len(column),
                         justify="right" if column == "ambient" else "left")
    for c in calibrations:
        ambient = f"{c.ambient_c:.1f} °C" if c.ambient_c is not None and \
            math.isfinite(c.ambient_c) else "-"
        table.add_row(shown(_when(c.date)),
                      shown(c.record_id) + (" SIMULATED" if c.simulated else ""),
                      shown(c.operator or "-"), shown(verdict_words(c.verdict)),
                      shown(acceptance_words(c)), ambient)
    console.print(table)
    for before, after in zip(calibrations, calibrations[1:], strict=False):
        if written.get(before.record_id):  # the first campaign after a write-back checks it
            console.print(shown(f"{after.record_id} validates the write-back made from "
                                f"{before.record_id}"), highlight=False)
    if any(c.simulated for c in calibrations):
        console.print("SIMULATED: a rehearsal on the built-in simulator, not a calibration "
                      "of the machine", highlight=False)
    values = Table(title=f"identified {'joint offsets ' if joint else ''}(mm ± U, k = 2; "
                         f"{DRIFT_MARK} changed by more than U)",
                   show_edge=False, header_style="bold", title_justify="left")
    values.add_column("date", no_wrap=True)
    for name in names:
        values.add_column(shown(_short(name)), justify="right", no_wrap=True)
    for c in calibrations:
        values.add_row(shown(_when(c.date)), *(_value(c, n, (c.record_id, n) in flagged)
                                               for n in names))
        wrote = written.get(c.record_id)
        if wrote and c is not calibrations[-1]:
            values.add_row("  written back", *(f"{wrote[n]:+.4f}" if n in wrote else ""
                                               for n in names), style="italic")
    console.print(values)
    if any(p.expanded_mm is None for c in calibrations for p in c.parameters.values()):
        console.print("* U unknown (no uncertainty budget): 2 x the fit's std shown and used",
                      highlight=False)
    flagged_drifts = [d for d in drifts if d.flagged]
    for d in flagged_drifts:
        console.print(f"[red]{DRIFT_MARK} {shown(d.describe())}[/]", highlight=False)
    if len(calibrations) > 1 and not flagged_drifts:
        console.print("no change between successive calibrations exceeds its U"
                      + (" (each judged from the state as left by the write-backs between)"
                         if any(written.get(c.record_id) for c in calibrations[:-1]) else ""))
    others = [e for e in events if e.kind != "calibration"]
    if others:
        counts = {k: sum(e.kind == k for e in others) for k in dict.fromkeys(e.kind for e in
                                                                            others)}
        hint = (f" (`ogacq history {machine.name!r} --states`: the offsets written)"
                if "write-back" in counts or "restore" in counts else "")
        console.print(shown("also recorded: " + ", ".join(f"{n} {k}{'s' if n > 1 else ''}"
                                                          for k, n in counts.items()) + hint),
                      highlight=False)


def print_states(machine: Machine, where: str, states: Sequence[OffsetState],
                 current: OffsetState | None,
                 machine_states: Sequence[MachineState] = ()) -> None:
    console = new_console()
    fate = {v.state_id: v.fate for v in machine_states if v.fate}
    table = Table(title=f"{shown(machine.describe())}: offsets states in {shown(where)} (o, mm)",
                  show_edge=False, header_style="bold", title_justify="left")
    for column in ("state", "when", "what", "record", "x", "y", "z", "status"):
        table.add_column(column, justify="right" if column in "xyz" else "left",
                         no_wrap=column in ("state", "when", "record"))
    for v in states:
        what = (f"before {v.action} {v.operation}" if v.stage == "before"
                else f"after {v.action} {v.operation}")
        mark = ", in force" if current is not None and v.state_id == current.state_id else ""
        told = f"; {fate[v.state_id]}" if v.state_id in fate else ""
        table.add_row(shown(v.state_id), shown(v.at or "-"), shown(what), shown(v.record_id),
                      *(f"{v.offsets_mm[a]:+.4f}" if v.offsets_mm[a] is not None else "-"
                        for a in "xyz"), shown(v.status + mark + told))
    console.print(table)
    maps = [v for v in machine_states if v.kind == "maps"]
    if maps:
        table = Table(title=f"{machine.describe()}: maps states (the error maps ogacq applies)",
                      show_edge=False, header_style="bold", title_justify="left")
        for column in ("state", "when", "what", "record", "axes", "checksum", "status"):
            table.add_column(column, no_wrap=column in ("state", "when", "record"))
        for m in maps:
            what = f"{m.stage} {m.action} {m.operation}"
            table.add_row(m.state_id, m.at or "-", what, m.record_id,
                          ", ".join(sorted(m.maps or {})) or "none",
                          (m.maps_checksum or "-")[:12],
                          m.status + (f"; {m.fate}" if m.fate else ""))
        console.print(table)
    if machine_states:
        console.print(f"compare two: ogacq history {machine.name!r} --states --diff STATE STATE",
                      highlight=False)
    if not states:
        console.print("no write-back of this machine is recorded")
    else:
        console.print(f"go back to one: ogacq offsets restore --machine "
                      f"{shown(repr(machine.name))} --to STATE (a state above, or a "
                      "calibration's record id)", highlight=False)


def calibrations_json(machine: Machine, calibrations: Sequence[Calibration],
                      drifts: Sequence[Drift]) -> dict[str, Any]:
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
                  f"({b['at'] or 'undated'}, {b['stage']} {b['action']} {b['operation']})",
                  highlight=False)
    table = Table(show_edge=False, header_style="bold")
    for column in ("axis", "offset from", "offset to", "change", "map"):
        table.add_column(column, justify="left" if column in ("axis", "map") else "right")
    for axis, o in compared["offsets_mm"].items():
        m = compared["maps"][axis]
        if m["change"] == "none":
            words = "unchanged" if m.get("from") else "none"
        else:
            words = (f"{m['change']} ({m.get('from') or '-'} -> {m.get('to') or '-'}): up to "
                     f"{m['max_forward_change_mm'] * 1000:.2f} µm forward, "
                     f"{m['max_reverse_change_mm'] * 1000:.2f} µm reverse")
        table.add_row(axis, *(f"{v:+.4f}" if v is not None else "-"
                              for v in (o["from"], o["to"], o["change"])), words)
    console.print(table)
    if not compared["maps_known"]:
        console.print("no maps state is recorded at or before these states", highlight=False)
