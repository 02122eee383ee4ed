"""The ``ogacq`` command: one typer app, errors turned into one line and exit 2."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Annotated

import typer
from typer.exceptions import TyperException

from drivers.errors import DriverError
from ogacq import __version__
from ogacq.cli.repeated_warnings import configure_logging, say_pending_repeats
from ogacq.io.errors import InputError, StorageError

app = typer.Typer(add_completion=False, no_args_is_help=True,
                  help="Acquisition and calibration for Orthoglide-type parallel machines.")

MachineOption = Annotated[Path, typer.Option("--machine", "-m", help="Machine file (TOML).")]
# For files that may record their machine (sessions do, CSVs do not).
RecordedMachineOption = Annotated[Path | None, typer.Option(
    "--machine", "-m", help="Machine file (TOML); a session's own is used when left out, "
                            "and one that differs from it is refused (--other-geometry).")]
OtherGeometryOption = Annotated[bool, typer.Option(
    "--other-geometry", help="Reanalyse a session with the --machine file even though it "
                             "differs from the machine the session was recorded with.")]
JsonOption = Annotated[bool, typer.Option("--json", help="Print one JSON object on stdout.")]


EXIT_DEVICE = 3  # a device fault or an unreachable device


class UserError(Exception):
    """A problem the user can fix, reported in one line with exit code 2."""


def _version(value: bool) -> None:
    if value:
        typer.echo(f"ogacq {__version__}")
        raise typer.Exit()


@app.callback()
def _root(version: Annotated[bool, typer.Option("--version", callback=_version,
                                                is_eager=True, help="Show the version.")]
          = False) -> None:
    pass


def _register() -> None:
    from ogacq.cli import (  # noqa: F401  (commands attach to app)
        campaign_cmds,
        diagnose_cmd,
        offsets_cmd,
        plan_cmd,
        refit_cmd,
        report_cmd,
        session_cmds,
        sim_cmd,
        wizard_cmd,
    )


def _run_app(argv: list[str] | None) -> object:
    try:
        # Outside standalone mode click returns typer.Exit's code instead of exiting.
        return app(args=argv, prog_name="ogacq", standalone_mode=False)
    finally:
        say_pending_repeats()  # before the command's last word


def main(argv: list[str] | None = None) -> int:
    configure_logging()
    _register()
    try:
        code = _run_app(argv)
    except (InputError, UserError) as exc:
        typer.echo(f"ogacq: error: {exc}", err=True)
        return 2
    except DriverError as exc:  # a device unreachable or failing before a campaign began
        typer.echo(f"ogacq: device error: {exc}", err=True)
        return EXIT_DEVICE
    except StorageError as exc:  # the disk, not the input: what was written stays intact
        typer.echo(f"ogacq: error: {exc}", err=True)
        return EXIT_DEVICE
    except typer.Exit as exc:
        return exc.exit_code
    except typer.Abort:
        typer.echo("ogacq: aborted", err=True)
        return 130
    except KeyboardInterrupt:
        typer.echo("ogacq: interrupted", err=True)
        return 130
    except TyperException as exc:  # usage errors (typer vendors its own click)
        show = getattr(exc, "show", None)
        if show is None:
            raise
        show()
        return getattr(exc, "exit_code", 2)
    return code if isinstance(code, int) else 0


if __name__ == "__main__":
    sys.exit(main())
