"""``ogacq`` as typer's group: every command, its help, completion and click's usage
errors. ``ogacq.cli.app.main`` comes here for every command line.

Command modules define plain functions and never import this module; the group
imports a command's module only when that command runs (``ogacq.cli.lazy``).
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Annotated

import typer

from ogacq import __version__
from ogacq.cli.command_table import COMMANDS, EXIT_CODES, FILE_FORMATS
from ogacq.cli.lazy import LazyCommands
from ogacq.cli.log_options import LOG_FILE_OPTION, VERBOSE_FLAGS, apply_log_options
from ogacq.cli.repeated_warnings import say_pending_repeats
from ogacq.cli.say import SIGPIPE_EXIT, pointed_at_null_device, reader_gone, say
from ogacq.cli.verdict_text import new_command


class OgacqCommands(LazyCommands):
    command_epilog = EXIT_CODES
    table = COMMANDS


# Completion asks the group for its commands' names only (``list_commands``), so the
# table is not imported to complete a command's name.
app = typer.Typer(cls=OgacqCommands, add_completion=True, no_args_is_help=True,
                  rich_markup_mode=None,
                  help="Acquisition and calibration for Orthoglide-type parallel machines.\n\n"
                       "New here? `ogacq demo` rehearses a whole calibration on the built-in "
                       "simulated machine; `ogacq wizard` guides one on a real machine, step "
                       "by step (`ogacq wizard --simulator` rehearses it first).",
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
              *VERBOSE_FLAGS, help="Also print info messages (retries, reconnections, "
                                      "steps) on the terminal, not only warnings.")] = False,
          log_file: Annotated[Path | None, typer.Option(
              LOG_FILE_OPTION, help="Append every log message, with its time, to this file "
                                 "(debug messages included).")] = None) -> None:
    apply_log_options(verbose, log_file)


def run_app(argv: list[str]) -> int:
    """Run ``argv`` through typer: click's own outcomes (an exit, an abort, the help,
    a usage error) become exit codes here; ogacq's errors go up to ``main``."""
    new_command()  # its first verdict said in full (ogacq/cli/verdict_text.py)
    try:
        try:
            # Outside standalone mode click returns typer.Exit's code instead of exiting.
            code = app(args=argv, prog_name="ogacq", standalone_mode=False)
        finally:
            say_pending_repeats()  # before the command's last word
    except typer.Exit as exc:
        return exc.exit_code
    except SystemExit as exc:
        # click's exit 1 when standard output's reader left, or rich's (which points
        # standard output at the null device first)
        if exc.code == 1 and (reader_gone() or pointed_at_null_device()):
            return SIGPIPE_EXIT
        raise
    except typer.Abort:
        print("ogacq: aborted", file=sys.stderr, flush=True)
        return 130
    except typer.TyperException as exc:  # click's usage errors: a bad option or value
        ctx = getattr(exc, "ctx", None)
        if ctx is not None and exc.format_message() == ctx.get_help():
            # `ogacq`, `ogacq session` alone: click's "error" is the help, shown as is
            typer.echo(exc.format_message(), err=True)
            return exc.exit_code
        hint = f" (see `{ctx.command_path} --help`)" if ctx is not None else ""
        say("error", exc.format_message() + hint)
        return exc.exit_code
    return code if isinstance(code, int) else 0
