"""The ``ogacq`` command: the table of commands, and every error turned into one line
and the exit code of its kind.

Command modules define plain functions and never import this module; the app imports
a command's module only when that command runs (``ogacq.cli.lazy``).
"""

from __future__ import annotations

import os
import sys
from pathlib import Path
from typing import Annotated

# One BLAS thread unless the user says otherwise: the analyses solve many small
# systems, where starting and parking OpenBLAS's threads costs a command ~0.1 s of its
# start-up and gains nothing. Set before numpy is first imported (by a command).
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import typer
from typer._click.exceptions import NoArgsIsHelpError  # typer vendors its own click

from ogacq import __version__
from ogacq.cli.lazy import LazyCommands, LazyCommandSpec, LazyGroupSpec
from ogacq.cli.log_options import apply_log_options, global_options_first
from ogacq.cli.plain import plain
from ogacq.cli.repeated_warnings import configure_logging, say_pending_repeats
from ogacq.errors import OgacqError

# The README's "Exit codes" table, in one paragraph.
EXIT_CODES = ("Exit codes: 0 done; 1 declined at a prompt; 2 bad input (a file, an option, a "
              "value); 3 a device failed or cannot be reached, or a campaign stopped (it can "
              "be resumed); 4 refused as unreliable or unsafe (the reasons are printed); "
              "130 interrupted.")

FILE_FORMATS = ("Files: machine, campaign, effects and offset-table files, readings and "
                "deviations CSVs are described in docs/formats.md (in the ogacq repository); "
                "`ogacq init machine|campaign` writes a commented template to start from.")

OFFSETS_HELP = ("Joint offsets on the controller: show the identified ones against the "
                "controller's, write them back (confirmed, read back, recorded), restore the "
                "old ones.")
SESSION_HELP = "Look at, export, import, check and salvage sessions."
MAPS_HELP = ("The error maps ogacq applies to every target (written by `ogacq calibrate`): "
             "show them with their ISO 230-2 figures, restore the ones a write replaced.")
HISTORY_HELP = ("Each machine's calibrations over time, in a database: `ogacq history MACHINE` "
                "(the same as `ogacq history show MACHINE`) lists them with each parameter's U "
                "and flags a drift larger than U; `ogacq history add SESSION...` records "
                "sessions afterwards. The history is --history URL_OR_PATH (an SQLite file or "
                "postgresql://USER@HOST/DATABASE), else $OGACQ_HISTORY, else history.sqlite in "
                "ogacq's data folder ($OGACQ_HOME, default ~/.local/share/ogacq), where "
                "every campaign records.")


class OgacqCommands(LazyCommands):
    command_epilog = EXIT_CODES
    # name -> the command's function and the summary `ogacq --help` lists (its docstring's
    # first paragraph: the help lists the commands without importing them), in that order
    table = {
        "run": LazyCommandSpec(
            "ogacq.cli.campaign_cmds:run",
            "Run a scripted campaign: no operator when the six gauges are mounted, or one "
            "asked to set them at each leg when indicators move from leg to leg."),
        "resume": LazyCommandSpec(
            "ogacq.cli.campaign_cmds:resume",
            "Continue an interrupted campaign where it stopped."),
        "demo": LazyCommandSpec(
            "ogacq.cli.demo_cmd:demo",
            "A full calibration campaign against the built-in simulator: identify the "
            "hidden joint offsets through the real drivers and compare them with the "
            "truth; then write them (and the error maps a table would hold), validate "
            "with a second campaign and keep or restore them, as `ogacq calibrate` "
            "does."),
        "calibrate": LazyCommandSpec(
            "ogacq.cli.calibrate_cmd:calibrate",
            "Calibrate the machine and validate it: campaign, diagnosis, the separating "
            "measurement when the diagnosis is ambiguous, offsets and error maps written "
            "(shown, confirmed, read back, audited), the compensation tables in the "
            "controllers' formats with their ISO 230-2 figures, a validation campaign, "
            "the record as found and as left; the previous state restored when the "
            "validation is worse, with the reason."),
        "diagnose": LazyCommandSpec(
            "ogacq.cli.diagnose_cmd:diagnose_command",
            "Compare the recordings with the identified model; locate and explain a "
            "mismatch."),
        "refit": LazyCommandSpec(
            "ogacq.cli.refit_cmd:refit",
            "Identify joint offsets and/or leg lengths from recorded data."),
        "plan": LazyCommandSpec(
            "ogacq.cli.plan_cmd:plan",
            "Predict the std of each parameter for a planned campaign."),
        "report": LazyCommandSpec(
            "ogacq.cli.report_cmd:report_command",
            "Write the calibration record: report.html (identification, instruments, "
            "environment, method, results with their uncertainty, acceptance, budget, "
            "history, then the analysis behind them), record.json with the same record, "
            "and the figures."),
        "sim": LazyCommandSpec(
            "ogacq.cli.sim_cmd:sim",
            "Serve a simulated machine on loopback and pseudo-terminals until Ctrl-C."),
        "wizard": LazyCommandSpec(
            "ogacq.cli.wizard_cmd:wizard",
            "Guided calibration: connect the instruments, set the gauges leg by leg, "
            "measure, identify the joint offsets."),
        "init": LazyCommandSpec(
            "ogacq.cli.init_cmd:init",
            "Write a commented template of a machine or a campaign file to edit."),
        "offsets": LazyGroupSpec(OFFSETS_HELP, {
            "show": "ogacq.cli.offsets_cmd:show",
            "write": "ogacq.cli.offsets_cmd:write",
            "restore": "ogacq.cli.offsets_cmd:restore"}),
        "maps": LazyGroupSpec(MAPS_HELP, {
            "show": "ogacq.cli.maps_cmd:show",
            "restore": "ogacq.cli.maps_cmd:restore"}),
        "history": LazyGroupSpec(HISTORY_HELP, {
            "show": "ogacq.cli.history_cmd:show",
            "add": "ogacq.cli.history_cmd:add"}, default="show"),
        "session": LazyGroupSpec(SESSION_HELP, {
            "show": "ogacq.cli.session_cmds:show",
            "export": "ogacq.cli.session_cmds:export",
            "import": "ogacq.cli.session_cmds:import_",
            "check": "ogacq.cli.session_cmds:check",
            "salvage": "ogacq.cli.session_cmds:salvage"}),
    }


# Completion asks the group for its commands' names only (``list_commands``), so the
# table is not imported to complete a command's name.
app = typer.Typer(cls=OgacqCommands, add_completion=True, no_args_is_help=True,
                  rich_markup_mode=None,
                  help="Acquisition and calibration for Orthoglide-type parallel machines.",
                  epilog=f"{EXIT_CODES}\n\n{FILE_FORMATS}")


def _version(value: bool) -> None:
    if value:
        typer.echo(f"ogacq {__version__}")
        raise typer.Exit()


@app.callback()
def _root(version: Annotated[bool, typer.Option("--version", callback=_version,
                                                is_eager=True, help="Show the version.")]
          = False,
          verbose: Annotated[bool, typer.Option(
              "--verbose", "-v", help="Also print info messages (retries, reconnections, "
                                      "steps) on the terminal, not only warnings.")] = False,
          log_file: Annotated[Path | None, typer.Option(
              "--log-file", help="Append every log message, with its time, to this file "
                                 "(debug messages included).")] = None) -> None:
    apply_log_options(verbose, log_file)


def _say(kind: str, message: str) -> None:
    """One line on stderr, whatever line breaks or control characters the message had
    (it may quote a recorded name, a file's line or a device's reply)."""
    text = " ".join(part.strip() for part in message.splitlines() if part.strip())
    typer.echo(f"ogacq: {kind}: {plain(text)}", err=True)


def _os_error(exc: OSError) -> str:
    """A file the system refused (a full disk, a read-only folder, a permission) that
    no command turned into its own error: the file and the reason, in one line."""
    where = ": ".join(str(f) for f in (exc.filename, exc.filename2) if f is not None)
    return f"{where}: {exc.strerror or exc}" if where else str(exc.strerror or exc)


def _run_app(argv: list[str] | None) -> object:
    try:
        # Outside standalone mode click returns typer.Exit's code instead of exiting.
        return app(args=argv, prog_name="ogacq", standalone_mode=False)
    finally:
        say_pending_repeats()  # before the command's last word


def main(argv: list[str] | None = None) -> int:
    configure_logging()
    argv = global_options_first(sys.argv[1:] if argv is None else list(argv))
    try:
        code = _run_app(argv)
    except OgacqError as exc:
        _say(exc.label, str(exc))
        return exc.exit_code
    except typer.Exit as exc:
        return exc.exit_code
    except typer.Abort:
        typer.echo("ogacq: aborted", err=True)
        return 130
    except KeyboardInterrupt:
        typer.echo("ogacq: interrupted", err=True)
        return 130
    except OSError as exc:  # the disk's fault, not the user's input: as a StorageError
        _say("error", _os_error(exc))
        return 3
    except NoArgsIsHelpError as exc:  # `ogacq`, `ogacq session`: the help
        exc.show()
        return exc.exit_code
    except typer.TyperException as exc:  # click's usage errors: a bad option or value
        ctx = getattr(exc, "ctx", None)
        hint = f" (see `{ctx.command_path} --help`)" if ctx is not None else ""
        _say("error", exc.format_message() + hint)
        return exc.exit_code
    return code if isinstance(code, int) else 0


if __name__ == "__main__":
    sys.exit(main())
