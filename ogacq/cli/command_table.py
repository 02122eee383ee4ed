"""The commands of ``ogacq``, by name: where each one's function is and the summary
``ogacq --help`` lists, without importing typer or any command.

``ogacq.cli.typer_app`` builds typer's group from this table, importing a command's
module only when it runs (``ogacq.cli.lazy``).
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any


@dataclass(frozen=True)
class LazyCommandSpec:
    """A command of the table: where its function is, and what the group's help says."""

    target: str  # "module:function"
    # the first paragraph of the function's docstring, which the group's help lists
    # (tests/cli/test_lazy_commands.py holds the two the same)
    summary: str


def import_target(target: str) -> Callable[..., Any]:
    """The function a ``"module:function"`` target names, its module imported."""
    module, _, name = target.partition(":")
    function: Callable[..., Any] = getattr(importlib.import_module(module), name)
    return function


@dataclass(frozen=True)
class LazyGroupSpec:
    """A group of sub-commands (``ogacq history ...``): its help and its commands."""

    help: str
    commands: Mapping[str, str]  # sub-command name -> "module:function"
    # the sub-command run when the first word names none (``ogacq history MACHINE``)
    default: str | None = None


# The README's "Exit codes" table, in one paragraph.
EXIT_CODES = ("Exit codes: 0 done; 1 declined at a prompt; 2 bad input (a file, an option, a "
              "value); 3 a device failed or cannot be reached, or a campaign stopped (it can "
              "be resumed); 4 refused as unreliable or unsafe (the reasons are printed); "
              "130 interrupted; 141 the reader of the output left (`| head`).")

FILE_FORMATS = ("Files: machine, campaign, effects and offset-table files, readings and "
                "deviations CSVs are described in docs/formats.md (in the ogacq repository); "
                "`ogacq init machine|campaign` writes a commented template to start from.")

OFFSETS_HELP = ("Joint offsets on the controller: show the identified ones against the "
                "controller's, write them back (confirmed, read back, recorded), restore the "
                "old ones.")
SESSION_HELP = "Look at, export, import, check and salvage sessions."
MAPS_HELP = ("The error maps ogacq applies to every target (written by `ogacq calibrate`): "
             "show them with their ISO 230-2 figures, restore the ones a write replaced.")
HISTORY_HELP = ("Each machine's calibrations over time, in a database: `ogacq history` lists "
                "the machines; `ogacq history MACHINE` "
                "(the same as `ogacq history show MACHINE`) lists them with each parameter's U "
                "and flags a drift larger than U; `ogacq history add SESSION...` records "
                "sessions afterwards. The history is --history URL_OR_PATH (an SQLite file or "
                "postgresql://USER@HOST/DATABASE), else $OGACQ_HISTORY, else history.sqlite in "
                "ogacq's data folder ($OGACQ_HOME, default ~/.local/share/ogacq), where "
                "every campaign records.")


# name -> the command's function and the summary `ogacq --help` lists (its docstring's
# first paragraph: the help lists the commands without importing them), in that order
COMMANDS: Mapping[str, LazyCommandSpec | LazyGroupSpec] = {
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
    "positioning": LazyCommandSpec(
        "ogacq.cli.positioning_cmd:positioning",
        "Test an axis's positioning with a scale along its actuator (ISO 230-2:2014): "
        "irregular targets over the travel, both directions, several runs, only that axis "
        "moving; prints the accuracy A, repeatability R, reversal B, systematic error E and "
        "M, and writes them as JSON beside the session."),
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
        "salvage": "ogacq.cli.session_cmds:salvage"}),}
