"""``ogacq session show|export|import|check|salvage``: sessions to look at, to exchange,
to check and to rescue."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from ogacq.cli.options import MachineOption
from ogacq.cli.outputs import ForceOption, check_new_file, check_output_file
from ogacq.cli.render import print_session
from ogacq.errors import InputError
from ogacq.io.machine_file import read_machine
from ogacq.session.convert import export_readings, import_readings
from ogacq.session.store import check_writable, load_session, salvage_session, scan_session


def show(session: Annotated[Path, typer.Argument(help="Session file.")]) -> None:
    """What a session holds: machine, station, progress, faults, result."""
    loaded = load_session(session)
    for warning in loaded.warnings:
        typer.echo(f"ogacq: warning: {warning}", err=True)
    print_session(loaded)


def export(
    session: Annotated[Path, typer.Argument(help="Session file.")],
    out: Annotated[Path, typer.Argument(help="Readings CSV to write.")],
    force: ForceOption = False,
) -> None:
    """Write the session's readings as a readings CSV (docs/formats.md)."""
    check_output_file(out, "OUT", force=force)
    count = export_readings(load_session(session), out)
    typer.echo(f"{count} readings written to {out}")


def import_(
    readings: Annotated[Path, typer.Argument(help="Readings CSV.")],
    out: Annotated[Path, typer.Argument(help="Session file to create.")],
    machine: MachineOption,
) -> None:
    """Make a session from a readings CSV (for tools that work on sessions)."""
    check_new_file(out, "OUT")  # its folder too: a session import makes no folders
    check_writable(out)
    path = import_readings(readings, read_machine(machine), out)
    typer.echo(f"session written to {path}")


def check(session: Annotated[Path, typer.Argument(help="Session file.")]) -> None:
    """Check every record (sequence, checksum, fields): what is wrong, and where."""
    scan = scan_session(session)
    for warning in scan.warnings:
        typer.echo(f"warning: {warning}")
    for line, problem in scan.problems:
        typer.echo(f"{session}:{line}: {problem}")
    if scan.problems:
        total = len(scan.records) + len(scan.problems)
        typer.echo(f"{len(scan.problems)} corrupt records of {total}; `ogacq session salvage "
                   f"{session} NEW` keeps the {len(scan.records)} valid ones")
        raise typer.Exit(2)
    load_session(session)  # the header too
    typer.echo(f"{session}: {len(scan.records)} records, every one valid")


def salvage(
    session: Annotated[Path, typer.Argument(help="Damaged session file (left as it is).")],
    out: Annotated[Path, typer.Argument(help="New session file to write.")],
) -> None:
    """Write every valid record of a damaged session to a new one; list the rest."""
    check_new_file(out, "OUT")
    kept, dropped = salvage_session(session, out)
    for line, problem in dropped:
        typer.echo(f"left out {session}:{line}: {problem}")
    typer.echo(f"{kept} records written to {out}; {len(dropped)} left out")
    if kept <= 1:
        raise InputError(session, "no record beyond the header was valid")
