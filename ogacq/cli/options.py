"""Options and choices that several commands share, so that each is spelled, checked
and documented once."""

from __future__ import annotations

from collections.abc import Iterable
from enum import StrEnum
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any, cast

import typer

if TYPE_CHECKING:
    from ogacq.model.machine import MachineSpec

MachineOption = Annotated[Path, typer.Option("--machine", "-m", help="Machine file (TOML).")]
# For files that may record their machine (sessions do, CSVs do not).
RecordedMachineOption = Annotated[Path | None, typer.Option(
    "--machine", "-m", help="Machine file (TOML); a session's own is used when left out, "
                            "and one that differs from it is refused (--other-geometry).")]
OtherGeometryOption = Annotated[bool, typer.Option(
    "--other-geometry", help="Reanalyse a session with the --machine file even though it "
                             "differs from the machine the session was recorded with.")]
JsonOption = Annotated[bool, typer.Option("--json", help="Print one JSON object on stdout.")]
# Where a finished campaign, diagnosis or write-back is recorded (ogacq.history.location).
HistoryOption = Annotated[str | None, typer.Option(
    "--history", metavar="URL_OR_PATH",
    help="Record into this history: an SQLite file or a PostgreSQL URL "
         "(default: $OGACQ_HISTORY, else history.sqlite in ogacq's data folder, $OGACQ_HOME "
         "or ~/.local/share/ogacq; none: record "
         "nothing).")]
# A session is analysed only when its campaign finished and its records are as written;
# these say the user means to analyse it as it stands (ogacq.session.state, .seal).
PartialOption = Annotated[bool, typer.Option(
    "--partial", help="Analyse a session whose campaign has not finished (running, stopped or "
                      "killed): every output says 'partial: N of M planned readings', and "
                      "nothing of it enters the history.")]
AcceptEditedOption = Annotated[bool, typer.Option(
    "--accept-edited", help="Analyse a session whose records were changed, removed or added "
                            "after they were written (see `ogacq session check`) as it "
                            "stands; every output and the record say so.")]
OverrideExpiredOption = Annotated[str | None, typer.Option(
    "--override-expired", metavar="REASON",
    help="Run although a gauge is past its calibration due date; the reason is recorded "
         "in the session (otherwise such a campaign is refused before anything moves).")]


def override_reason(given: str | None) -> str:
    """The stated reason of --override-expired: a blank one is no reason."""
    if given is None:
        return ""
    if not given.strip():
        raise typer.BadParameter("give the reason (what makes the measurement valid all "
                                 "the same)", param_hint="--override-expired")
    return given.strip()


def axis_scales_option(help: str) -> Any:
    """``--axis-scales AXES``: the axes along which the simulator serves a scale."""
    return typer.Option("--axis-scales", metavar="AXES", help=help)


def scale_axes(given: str) -> tuple[str, ...]:
    """``--axis-scales``'s axes, sorted and once each; InputError naming another."""
    from ogacq.errors import InputError

    axes = tuple(sorted({a.strip() for a in given.split(",") if a.strip()}))
    bad = [a for a in axes if a not in ("x", "y", "z")]
    if bad:
        raise InputError("--axis-scales", f"names axes x, y or z, got {', '.join(bad)}")
    return axes


def confirmed(question: str) -> bool:
    """A yes/no question, no by default; the end of input or Ctrl-C at it is a no."""
    try:
        return typer.confirm(question, default=False)
    except typer.Abort:
        typer.echo("", err=True)  # the prompt's line ended
        return False


# One default for every simulated machine (demo, sim, wizard): a rehearsal with the
# defaults meets the machine the demo showed. 1, not 0: the demo's seed, whose hidden
# offsets differ visibly from axis to axis.
DEFAULT_SEED = 1
# ... and one pace: the simulated machine's time runs this many times faster than real
# time in every rehearsal (demo, calibrate --simulator, the wizard's, ogacq sim)
DEFAULT_SPEED = 25.0
# Under the folder the command was started in, one level down: the runs of demo and
# calibrate gather in one place (ignored by git) instead of beside the package, where a
# search would pack them.
RUNS_FOLDER = Path("ogacq-runs")
# The rehearsal's acceptance: every leg-parallelism deviation within +/- 20 um, judged
# with the guard band (no source: a stated example, as a machine file would state it)
SIM_TOLERANCE_MM = 0.020


def simulated_machine(seed: int) -> MachineSpec:
    """The machine demo and calibrate --simulator rehearse on: the papers' digital
    prototype, its serial from the seed (the history tells one seed's from another's)."""
    from dataclasses import replace

    from ogacq.model.machine import PAPER_PROTOTYPE_DIGITAL
    from ogacq.model.tolerances import Tolerances

    return replace(PAPER_PROTOTYPE_DIGITAL, serial=f"SIM-{seed}",
                   tolerances=Tolerances(default_mm=SIM_TOLERANCE_MM))


def login_name(fallback: str) -> str:
    """Who runs a rehearsal when no --operator names them: the login name, else
    ``fallback`` (no user name in the environment or the password file)."""
    import getpass

    try:
        return getpass.getuser()
    except (KeyError, OSError):
        return fallback


def seed_option(help: str) -> Any:
    """A random seed: numpy's generators take none below 0, so typer refuses it at parsing."""
    return typer.Option(min=0, help=help)


class IndicatorCount(StrEnum):
    """How many dial indicators a station has: the only two layouts the plan knows."""

    in_place = "6"  # two per leg, left in place
    moved = "2"  # moved from leg to leg, as in the papers


class ParamSet(StrEnum):
    offsets = "offsets"
    lengths = "lengths"
    both = "both"


if TYPE_CHECKING:  # their members are known at run time only (below)
    class ProfileChoice(StrEnum):
        """A controller profile shipped with the drivers."""

    class GaugeProtocol(StrEnum):
        """A protocol of the drivers' table."""


def profile_help(lead: str) -> str:
    """``lead``, then each controller profile shipped with the drivers as its file
    describes it: the profiles ProfileChoice offers, not a list kept by hand."""
    from ogacq_drivers.axes.profile import available_profiles, load_profile

    return f"{lead}: " + "; ".join(f"{name} ({load_profile(name).description})"
                                   for name in available_profiles()) + "."


def per_axis_profiles() -> str:
    """The profiles whose axes are each their own endpoint ("mr-je-c"), in words."""
    from ogacq_drivers.axes.profile import available_profiles, load_profile

    return " and ".join(n for n in available_profiles() if load_profile(n).endpoint_per_axis)


def _choice(name: str, values: Iterable[str]) -> type[StrEnum]:
    # Enum's functional API makes a class; the stubs read the call as a member lookup
    return cast("type[StrEnum]", StrEnum(name, {v: v for v in values}))


def __getattr__(name: str) -> type[StrEnum]:
    """The device choices, built when a command asks for them: the drivers they list
    cost start-up time that the analysis commands (refit, diagnose) do not need."""
    if name == "ProfileChoice":
        # Every controller profile shipped with the drivers, so a new register map is
        # offered as soon as its file is there.
        from ogacq_drivers.axes.profile import available_profiles
        choice = _choice("ProfileChoice", available_profiles())
    elif name == "GaugeProtocol":
        # Every protocol of the driver table, so a new cable is served as soon as it
        # has a driver.
        from ogacq_drivers.indicators import BACKENDS
        choice = _choice("GaugeProtocol", BACKENDS)
    else:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    globals()[name] = choice  # built once
    return choice
