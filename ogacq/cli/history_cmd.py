"""``ogacq history MACHINE`` and ``ogacq history add SESSION...``: a machine's
calibrations over time, and sessions recorded into the history afterwards."""

from __future__ import annotations

import json
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import typer

from ogacq.cli.options import AcceptEditedOption, JsonOption
from ogacq.cli.outputs import ForceOption, check_output_file
from ogacq.cli.plain import print_wrapped
from ogacq.errors import InputError, OgacqError, Refused
from ogacq.history.drift import changes, controller_changes, written_by_record
from ogacq.history.entries import RecordError, check_record
from ogacq.history.location import HistoryLocation, history_for_session, history_to_read
from ogacq.history.recording import (
    filed_by_name,
    record_session,
    session_record,
    writebacks_of,
)
from ogacq.history.states import diff as states_diff
from ogacq.history.states import find, timeline
from ogacq.history.tail import cut_tail
from ogacq.record.declared import RecordSectionError
from ogacq.session.state import completeness, taken_as_it_stands, unsealed
from ogacq.session.store import LoadedSession, load_session

if TYPE_CHECKING:
    from ogacq.history.store import History

# the history shown or added to (`none` is no history: ogacq.history.location refuses it)
TheHistoryOption = Annotated[str | None, typer.Option(
    "--history", metavar="URL_OR_PATH",
    help="The history: an SQLite file, or a postgresql://USER@HOST/DB URL. Default: "
         "$OGACQ_HISTORY, else history.sqlite in ogacq's data folder ($OGACQ_HOME, default "
         "~/.local/share/ogacq).")]
AcceptUnsealedOption = Annotated[bool, typer.Option(
    "--accept-unsealed", help="Record a session that cannot vouch for all it held (its "
                              "seals stripped or older, a torn record, not closed: killed, "
                              "or its last records removed) as it stands; its record in the "
                              "history says so.")]


def _opened(location: HistoryLocation, *, create: bool = False) -> History:
    """The history at ``location``: SQLAlchemy and the dialect in use are imported here,
    when a history is read or written, not for ``--help``."""
    from ogacq.history.store import History

    return History.open(location, create=create)


def show(
    machine: Annotated[str | None, typer.Argument(
        help="The machine's name (or its serial), as its machine file gives it; none: the "
             "machines the history holds.")] = None,
    history: TheHistoryOption = None,
    states: Annotated[bool, typer.Option(
        "--states", help="List the offsets each write-back and restore found and left on "
                         "the controller (what `ogacq offsets restore --to` takes), the maps "
                         "each maps write left, and what calibrate made of them.")] = False,
    diff: Annotated[tuple[str, str] | None, typer.Option(
        "--diff", metavar="STATE STATE", help="With --states: what changed between two "
                                              "states (offsets and maps).")] = None,
    plot: Annotated[Path | None, typer.Option(
        "--plot", metavar="FILE.png", help="Also draw each parameter over time with its U "
                                           "(PNG).")] = None,
    force: ForceOption = False,
    as_json: JsonOption = False,
) -> None:
    """A machine's calibrations: date, record, operator, each parameter with its U, fit
    verdict, acceptance, ambient temperature; a change from one calibration to the next
    larger than its U (root sum of squares of both U) is flagged as a drift.

    The history is --history, else $OGACQ_HISTORY, else history.sqlite in ogacq's data
    folder ($OGACQ_HOME, default ~/.local/share/ogacq).
    """
    from ogacq.cli import render_history as render  # with the history's types, when used

    _check_show_options(machine, states, diff, plot, force)
    location = history_to_read(history)
    if machine is None:
        _list_machines(location, as_json)
        return
    if not (states or plot is not None or as_json):
        _show_each(location, machine)  # a name that fits several machines lists each
        return
    with _opened(location) as db:
        found = db.find_machine(machine)
        if states:
            listed = db.states(found)
            current = db.current_state(found)
            machine_states = timeline(listed, db.map_states(found), db.calibrate_events(found))
        else:
            calibrations = db.calibrations(found)
            events = db.events(found)
            written = written_by_record(db.states(found))
    where = location.describe()
    if states and diff is not None:
        compared = states_diff(find(machine_states, diff[0]), find(machine_states, diff[1]))
        if as_json:
            typer.echo(json.dumps(compared))
        else:
            render.print_diff(found, compared)
        return
    if states:
        if as_json:
            typer.echo(json.dumps(render.states_json(found, listed, current, machine_states)))
        else:
            render.print_states(found, where, listed, current, machine_states)
        return
    drifts = changes(calibrations, written)
    moves = controller_changes(calibrations, written)
    if plot is not None:
        from ogacq.history.plot import write_history_plot  # matplotlib only when asked

        write_history_plot(plot, found.describe(), calibrations, drifts, written)
    if as_json:
        typer.echo(json.dumps(render.calibrations_json(found, calibrations, drifts, moves)))
        return
    render.print_calibrations(found, where, calibrations, drifts, events, written, moves)
    if plot is not None:
        print_wrapped(f"plot: {plot}")


def _show_each(location: HistoryLocation, typed: str) -> None:
    """Every machine ``typed`` names (two machines may share a name: the demo's
    simulator and a machine file's), each with its calibrations."""
    from ogacq.cli import render_history as render

    with _opened(location) as db:
        found = db.find_machines(typed) or [db.find_machine(typed)]  # none: say which exist
        each = [(m, db.calibrations(m), db.events(m), written_by_record(db.states(m)))
                 for m in found]
    for machine, calibrations, events, written in each:
        render.print_calibrations(machine, location.describe(), calibrations,
                                  changes(calibrations, written), events, written,
                                  controller_changes(calibrations, written))
    if len(found) > 1:
        print_wrapped(f"{typed!r} names {len(found)} machines: one of them alone is "
             f"`ogacq history {found[0].label!r}`")


def _check_show_options(machine: str | None, states: bool, diff: tuple[str, str] | None,
                        plot: Path | None, force: bool) -> None:
    """The options of ``history show`` that cannot go together, refused before the
    history is opened."""
    if plot is not None:
        if plot.suffix.lower() != ".png":
            raise InputError(plot, "the plot is a PNG image: name it FILE.png")
        check_output_file(plot, "--plot", force=force)
    if diff is not None and not states:
        raise InputError("--diff", "compares two states: give it with --states")
    if machine is None and (states or plot is not None):
        raise InputError("--states" if states else "--plot", "is about one machine: give its "
                         "name (`ogacq history` alone lists them)")


def _list_machines(location: HistoryLocation, as_json: bool) -> None:
    """The machines the history holds, each with its calibrations' count and the last
    one's date: what a technician who forgot a machine's exact name needs."""
    with _opened(location) as db:
        listed = [(m, db.calibrations(m)) for m in db.machines()]
    rows = [{"name": m.name, "serial": m.serial or None, "calibrations": len(cals),
             "last": max((c.date for c in cals if c.date), default=None)}
            for m, cals in listed]
    if as_json:
        typer.echo(json.dumps({"history": location.describe(), "machines": rows}))
        return
    print_wrapped(f"machines in history {location.describe()}:" if rows else
         f"history {location.describe()} holds no machine yet")
    for (m, _), row in zip(listed, rows, strict=True):
        count = row["calibrations"]
        # the date as the machine's table writes it (2026-12-06 21:53)
        last = f", the last {str(row['last'])[:16].replace('T', ' ')}" if row["last"] else ""
        print_wrapped(f"  {m.label}: {count} calibration{'s' if count != 1 else ''}{last}")
    if any(not m.serial for m, _ in listed):  # its identity is its name: said once
        print_wrapped("a machine with no serial is filed by its name alone: `serial = ...` in its "
             "machine file tells it from another of the same name")
    if rows:
        print_wrapped(f"`ogacq history {listed[0][0].label!r}` lists a machine's calibrations (its "
             "name, serial or the label above)")


def _record_for_history(session: LoadedSession) -> dict[str, Any]:
    """The session's record, refused (before anything is written) when the history
    cannot file it: a session recorded from a machine file whose name was blank."""
    try:
        return check_record(session_record(session))
    except (RecordError, RecordSectionError) as exc:
        raise InputError(session.path, f"{exc}: the history files calibrations by machine, "
                         "so this session cannot enter one") from None


def seen_more(session: LoadedSession, location: HistoryLocation) -> tuple[int, str] | None:
    """(line, why) when the history saw more records of the session than its file holds;
    None too when there is no history yet (it saw nothing), made by the recording."""
    try:
        with _opened(location) as db:
            return cut_tail(db, session)
    except OgacqError:
        return None


def _vouched_for(session: LoadedSession, location: HistoryLocation,
                 accept_unsealed: bool) -> LoadedSession:
    """The session, refused when it cannot vouch for all it held (seals stripped, a torn
    record, not closed, fewer records than the history saw) unless the user accepts it
    as it stands: then with that among its edits, which its record carries."""
    found = unsealed(session) or seen_more(session, location)
    if found is None:
        return session
    line, problem = found
    if not accept_unsealed:
        raise Refused(f"{session.path}:{line}: {problem}; nothing was recorded: "
                      "--accept-unsealed records it as it stands (its record in the history "
                      "then says so)")
    return taken_as_it_stands(session, line, problem)


def add(
    sessions: Annotated[list[Path], typer.Argument(
        help="Session files of finished campaigns (their write-backs come along).")],
    history: TheHistoryOption = None,
    accept_edited: AcceptEditedOption = False,
    accept_unsealed: AcceptUnsealedOption = False,
) -> None:
    """Record sessions into the history afterwards: each session's calibration record,
    rebuilt from the file, and the write-backs and restores its audit holds. A session
    recorded before is not recorded twice; a campaign not finished gives no
    calibration (its write-backs are recorded: the controller was changed)."""
    # every file and place checked before any write
    loaded = [load_session(path, accept_edited=accept_edited) for path in sessions]
    locations = [history_for_session(history, session.path) for session in loaded]
    if None in locations:
        raise InputError("--history", "is 'none': there is no history to add to")
    for session in loaded:
        state = completeness(session)
        if not state.complete and not writebacks_of(session):
            raise Refused(f"{session.path}: {state.describe()}: a calibration enters the "
                          "history when its campaign completes; nothing was recorded")
    loaded = [_vouched_for(session, location, accept_unsealed)
              for session, location in zip(loaded, locations, strict=True) if location]
    records = [_record_for_history(session) for session in loaded]
    for session, record, location in zip(loaded, records, locations, strict=True):
        assert location is not None
        with _opened(location, create=True) as db:
            first_met = filed_by_name(db, session)
            recorded = record_session(db, session, record)
        what = ", ".join(recorded.new) if recorded.new else "already recorded"
        state = completeness(session)
        if not state.complete:
            what += f"; no calibration: {state.describe()}"
        for note in session.integrity.notes():
            what += f"; {note}"
        print_wrapped(f"{session.path}: {what} ({location.describe()})")
        if first_met is not None and recorded.new:
            print_wrapped(first_met)
