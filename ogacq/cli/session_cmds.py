"""``ogacq session show|export|import|check|salvage``: sessions to look at, to exchange,
to check and to rescue."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from ogacq.cli.options import AcceptEditedOption, MachineOption, PartialOption
from ogacq.cli.outputs import ForceOption, check_new_file, check_output_file
from ogacq.cli.plain import print_wrapped
from ogacq.cli.render import print_session
from ogacq.io.machine_file import read_machine
from ogacq.session.convert import export_readings, import_readings
from ogacq.session.seal import UNCHECKED
from ogacq.session.state import completeness, require_complete, session_notes, unproven_end
from ogacq.session.store import (
    LoadedSession,
    check_writable,
    load_session,
    salvage_session,
    scan_session,
)


def show(session: Annotated[Path, typer.Argument(help="Session file.")]) -> None:
    """What a session holds: machine, station, progress, faults, result; whether its
    campaign finished and whether it was edited (shown as it stands, and said)."""
    loaded = load_session(session, accept_edited=True)  # a look, not an analysis
    for warning in loaded.warnings:
        typer.echo(f"ogacq: warning: {warning}", err=True)
    print_session(loaded, completeness(loaded))


def export(
    session: Annotated[Path, typer.Argument(help="Session file.")],
    out: Annotated[Path, typer.Argument(help="Readings CSV to write.")],
    force: ForceOption = False,
    partial: PartialOption = False,
    accept_edited: AcceptEditedOption = False,
) -> None:
    """Write the session's readings as a readings CSV (docs/formats.md)."""
    check_output_file(out, "OUT", force=force)
    loaded = load_session(session, accept_edited=accept_edited)
    state = require_complete(loaded, partial)
    for note in session_notes(loaded, state):
        print_wrapped(note)
    count = export_readings(loaded, out)
    print_wrapped(f"{count} readings written to {out}")


def import_(
    readings: Annotated[Path, typer.Argument(help="Readings CSV.")],
    out: Annotated[Path, typer.Argument(help="Session file to create.")],
    machine: MachineOption,
) -> None:
    """Make a session from a readings CSV (for tools that work on sessions)."""
    check_new_file(out, "OUT")  # its folder too: a session import makes no folders
    check_writable(out)
    path = import_readings(readings, read_machine(machine), out)
    print_wrapped(f"session written to {path}")


def check(session: Annotated[Path, typer.Argument(help="Session file.")]) -> None:
    """Check every record (sequence, chain, checksum, fields): what is wrong, and where;
    whether the file ends where its last writer closed it; and whether the campaign
    finished. Exit 2 when a record is corrupt or edited, or the end is not closed."""
    scan = scan_session(session)
    for warning in scan.warnings:
        print_wrapped(f"warning: {warning}")
    for line, problem in sorted(scan.problems + scan.edited):
        typer.echo(f"{session}:{line}: {problem}")  # FILE:LINE: one line, as editors read it
    total = len(scan.records) + len(scan.problems)
    if scan.problems or scan.edited:
        bad = len(scan.problems) + len(scan.changed)
        print_wrapped(f"{len(scan.problems)} corrupt and {len(scan.edited)} edited records of "
                      f"{total}; `ogacq session salvage {session} NEW` keeps the "
                      f"{total - bad} as written")
        raise typer.Exit(2)
    loaded = load_session(session)  # the header too
    if scan.mode == UNCHECKED:
        print_wrapped(f"{session}: {total} records, unchecked: written before ogacq checksummed "
                      "its records (an edit to it cannot be found)")
        return
    open_end = unproven_end(loaded) or _history_says_cut(loaded)
    if open_end is not None:
        print_wrapped(f"{session}: {total} records as written ({scan.mode}), but {open_end}; "
                      f"{completeness(loaded).describe()}")
        raise typer.Exit(2)
    closed = ", closed by its last writer" if loaded.closure.closed else ""
    print_wrapped(f"{session}: {total} records, every one as written ({scan.mode}{closed}); "
                  f"{completeness(loaded).describe()}")


def _history_says_cut(session: LoadedSession) -> str | None:
    """Why the history's own count says the session lost records at its end, when the
    history of this account holds it (a history that cannot be read says nothing)."""
    from ogacq.cli.history_cmd import seen_more
    from ogacq.errors import OgacqError
    from ogacq.history.location import history_to_read

    try:
        found = seen_more(session, history_to_read(None))
    except OgacqError:  # no history on this account
        return None
    return None if found is None else found[1]


def salvage(
    session: Annotated[Path, typer.Argument(help="Damaged session file (left as it is).")],
    out: Annotated[Path, typer.Argument(help="New session file to write.")],
) -> None:
    """Write every record of a damaged session as it was written to a new one (written
    whole or not at all); list the rest."""
    check_new_file(out, "OUT")
    kept, dropped = salvage_session(session, out)
    for line, problem in dropped:
        typer.echo(f"left out {session}:{line}: {problem}")  # FILE:LINE: one line
    print_wrapped(f"{kept} records written to {out}; {len(dropped)} left out")
