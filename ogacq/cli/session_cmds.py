"""``ogacq session show|export|import``: sessions to look at and to exchange."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from ogacq.cli.app import MachineOption, app
from ogacq.io.machine_file import read_machine
from ogacq.session.convert import export_readings, import_readings
from ogacq.session.store import load_session

session_app = typer.Typer(no_args_is_help=True, help="Look at, export and import sessions.")
app.add_typer(session_app, name="session")


@session_app.command("show")
def show(session: Annotated[Path, typer.Argument(help="Session file.")]) -> None:
    """What a session holds: machine, station, progress, faults, result."""
    from ogacq.cli.render import print_session

    loaded = load_session(session)
    for warning in loaded.warnings:
        typer.echo(f"ogacq: warning: {warning}", err=True)
    print_session(loaded)


@session_app.command("export")
def export(
    session: Annotated[Path, typer.Argument(help="Session file.")],
    out: Annotated[Path, typer.Argument(help="Readings CSV to write.")],
) -> None:
    """Write the session's readings as a readings CSV (INTERCHANGE.md)."""
    if out.exists():
        raise typer.BadParameter(f"{out} exists; not overwriting it", param_hint="OUT")
    count = export_readings(load_session(session), out)
    typer.echo(f"{count} readings written to {out}")


@session_app.command("import")
def import_(
    readings: Annotated[Path, typer.Argument(help="Readings CSV.")],
    out: Annotated[Path, typer.Argument(help="Session file to create.")],
    machine: MachineOption,
) -> None:
    """Make a session from a readings CSV (for tools that work on sessions)."""
    path = import_readings(readings, read_machine(machine), out)
    typer.echo(f"session written to {path}")
