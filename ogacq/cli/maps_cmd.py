"""``ogacq maps show|restore``: the error maps ogacq applies (written by ``ogacq
calibrate``, audited in its session), and undoing the session's last maps write."""

from __future__ import annotations

import contextlib
import json
from pathlib import Path
from typing import Annotated

import typer

from ogacq.cli.options import HistoryOption, JsonOption, confirmed
from ogacq.cli.plain import plain, print_wrapped
from ogacq.compensation.iso230 import map_figures
from ogacq.errors import InputError, Refused
from ogacq.session.store import LoadedSession, load_session
from ogacq.writeback.audit import AuditLog
from ogacq.writeback.endpoint_lock import holding, maps_key
from ogacq.writeback.maps import MapsFile, MapsOperation
from ogacq.writeback.maps_table import read_maps_table
from ogacq.writeback.write_target import restore as restore_target

EXIT_DECLINED = 1
SessionArgument = Annotated[Path, typer.Argument(
    help="Session whose maps writes to show or undo (a calibration campaign's).")]


def show(session_path: SessionArgument, as_json: JsonOption = False) -> None:
    """The session's maps writes, and the maps the file holds now with their figures."""
    session = load_session(session_path)
    ops = MapsFile.operations(session)
    if not ops:
        raise InputError(session.path, "no maps write is recorded in this session")
    table = read_maps_table(ops[-1].path)
    figures = {a: map_figures(m).to_json() for a, m in table.maps.items()}
    if as_json:
        typer.echo(json.dumps({
            "file": str(table.path), "checksum": table.checksum,
            "maps": {a: m.source for a, m in table.maps.items()}, "figures": figures,
            "writes": [{"operation": o.operation, "action": o.action, "status": o.status,
                        "old_checksum": o.old_checksum, "new_checksum": o.new_checksum}
                       for o in ops]}))
        return
    for o in ops:
        print_wrapped(f"{o.operation} ({o.action}, {o.status}): {o.old_checksum[:12]} -> "
                      f"{o.new_checksum[:12]}")
    print_wrapped(f"maps file {plain(table.path)}: {table.checksum[:12]}"
                  + ("" if table.maps else " (no maps)"))
    for axis, m in table.maps.items():
        print_wrapped(f"  {axis}: {m.source or 'map'}; ISO 230-2: "
                      f"{map_figures(m).line()}")


def restore(
    session_path: SessionArgument,
    yes: Annotated[bool, typer.Option("--yes", "-y", help="Restore without asking.")] = False,
    history: HistoryOption = None,
) -> None:
    """Put back the maps the session's last maps write replaced."""
    session = load_session(session_path)
    writes = [o for o in MapsFile.operations(session) if o.action == "write"]
    if not writes:
        raise InputError(session.path, "no maps write is recorded in this session: nothing "
                         "to restore")
    op = writes[-1]
    target = MapsFile(op.path)
    with holding([maps_key(op.path)]):  # not while a campaign applies them
        _confirm_and_restore(session, op, target, yes=yes, history=history)


def _confirm_and_restore(session: LoadedSession, op: MapsOperation, target: MapsFile, *,
                         yes: bool, history: str | None) -> None:
    plan = target.plan_restore(op, target.held())
    print_wrapped(f"maps file {plain(plan.path)}: {plan.current.checksum[:12]} -> "
                  f"{plan.new_checksum[:12]} (back to before {op.operation}; "
                  f"{', '.join(plan.new_maps) or 'no maps'})")
    if plan.nothing_to_do:
        print_wrapped("the maps file already holds these maps: nothing to restore")
        return
    if plan.refused:
        raise Refused("nothing restored: " + "; ".join(r.message for r in plan.refusals))
    if not yes and not confirmed("Restore these maps?"):
        typer.echo("nothing restored", err=True)
        raise typer.Exit(EXIT_DECLINED)
    try:
        with AuditLog(session) as audit:
            done = restore_target(target, op, session, audit,
                                  "--yes" if yes else "prompt")
        print_wrapped(f"restored: {done}, read back {target.held()[:12]}")
    finally:
        from ogacq.history.recording import record_writebacks

        with contextlib.suppress(InputError):
            record_writebacks(session.path, history)
