"""``ogacq run`` and ``ogacq resume``: campaigns from the command line, and the
progress and result display ``ogacq demo`` shares with them."""

from __future__ import annotations

import contextlib
import json
import logging
import math
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Annotated

import typer

from ogacq.campaign.campaign_file import Campaign, read_campaign
from ogacq.campaign.run import CampaignOutcome, resumable_campaign, run_campaign
from ogacq.campaign.traceability import traceability_gaps
from ogacq.cli.campaign_end import campaign_end
from ogacq.cli.leg_prompt import operator_for
from ogacq.cli.options import HistoryOption, JsonOption, OverrideExpiredOption, override_reason
from ogacq.cli.plain import plain
from ogacq.cli.render import CampaignProgress, campaign_progress, print_end, print_outcome
from ogacq.history.recording import record_campaign
from ogacq.protocol.runner import CampaignStopped
from ogacq.session.series import next_session
from ogacq.session.store import LoadedSession, load_session
from ogacq.writeback.maps_binding import check_campaign_maps

log = logging.getLogger("ogacq")


SessionOption = Annotated[Path | None, typer.Option(
    "--session", metavar="FILE",
    help="Record into this new session file instead of the campaign's (default: the "
         "campaign's session; once that holds a complete campaign, the next free "
         "SESSION-2.jsonl, SESSION-3.jsonl beside it).")]


def run(
    campaign_file: Annotated[Path, typer.Argument(help="Campaign file (TOML).")],
    as_json: JsonOption = False,
    history: HistoryOption = None,
    override_expired: OverrideExpiredOption = None,
    session: SessionOption = None,
) -> None:
    """Run a scripted campaign: no operator when the six gauges are mounted, or one
    asked to set them at each leg when indicators move from leg to leg."""
    reason = override_reason(override_expired)
    campaign = read_campaign(campaign_file)
    _run_checked(campaign, None, reason, as_json, history, session)


def resume(
    session: Annotated[Path, typer.Argument(help="Session file of an interrupted campaign.")],
    as_json: JsonOption = False,
    history: HistoryOption = None,
    override_expired: OverrideExpiredOption = None,
) -> None:
    """Continue an interrupted campaign where it stopped."""
    reason = override_reason(override_expired)
    loaded = load_session(session)
    _run_checked(resumable_campaign(loaded), loaded, reason, as_json, history)


def _run_checked(campaign: Campaign, resume: LoadedSession | None, reason: str,
                 as_json: bool, history: str | None, session: Path | None = None) -> None:
    """A campaign run or resumed once what it needs is checked, before anything opens:
    an operator where indicators move, the session it records into (a new run), the
    maps the history says are in force."""
    if reason:
        campaign.override_expired = reason
    operator_for(campaign)  # refuses one that needs an operator
    if resume is None:
        campaign.session = _session_for(campaign.session, session)
    check_campaign_maps(campaign, history)
    outcome = execute(lambda obs: run_campaign(
        campaign, resume=resume, observer=obs, set_gauges=operator_for(campaign, obs),
        checked=lambda: warn_traceability(campaign)), campaign.session, quiet=as_json)
    finish(outcome, as_json, history)


def _session_for(campaign_session: Path, given: Path | None) -> Path:
    """The session this run records into: ``--session``, else the campaign's or the
    next of its series once it is complete (said on the terminal)."""
    if given is not None:
        return given  # an existing file is refused before anything opens
    chosen = next_session(campaign_session)
    if chosen.previous is not None:
        typer.echo(f"ogacq: {chosen.previous} holds a complete campaign: this run records "
                   f"into {chosen.path} (--session FILE names another)", err=True)
    return chosen.path


def warn_traceability(campaign: Campaign) -> None:
    """Once the campaign passed its gates and its station opened, before anything
    moves: what the record will lack (an operator, a certificate)."""
    for gap in traceability_gaps(campaign):
        log.warning("%s: %s", campaign.path, gap)


def finish(outcome: CampaignOutcome, as_json: bool, history: str | None) -> None:
    """The end of a campaign: the offsets with their U, the record into the history,
    then the verdict, the record id and what to do next."""
    # `ogacq sim`'s controller still serves: the write-back can be rehearsed on it
    end = campaign_end(outcome.session_path, outcome.fit, simulated=outcome.simulated,
                       rehearsal_writeback=not outcome.controller_gone)
    if as_json:
        # the refit object, then what the end of a campaign says in words: the
        # verdict, the record's id and the next commands (a script needs them too)
        typer.echo(json.dumps({"session": str(outcome.session_path),
                               **outcome.fit.to_json("offsets"), "hidden": outcome.hidden,
                               "simulated": outcome.simulated,
                               "verdict": {k: v if not isinstance(v, float) or math.isfinite(v)
                                           else None for k, v in end.verdict.to_record().items()},
                               "record_id": end.record_id if end.built else None,
                               "next": [{"command": s.command or None, "why": s.why}
                                        for s in end.steps]}))
    else:
        print_outcome(outcome, end.record)
    record_campaign(outcome.session_path, history, record=end.built)
    if not as_json:
        print_end(end.lines())


def execute(start: Callable[[CampaignProgress], CampaignOutcome], session: Path, *,
            quiet: bool = False) -> CampaignOutcome:
    """Run ``start(observer)`` with progress shown; a stop exits non-zero with its reason
    and the command that continues ``session``."""
    with campaign_progress(enabled=not quiet) as observer, said_if_stopped(
            "campaign", f"the session is saved: continue it with `ogacq resume {session}`"):
        return start(observer)


@contextlib.contextmanager
def said_if_stopped(what: str, then: str) -> Iterator[None]:
    """A stopped campaign (run, positioning test, procedure) said on stderr: ``what``,
    its status and reason, then how to continue it (``then``); its exit code."""
    try:
        yield
    except CampaignStopped as stop:
        typer.echo(f"ogacq: {what} {stop.status}: {plain(stop.reason)}", err=True)
        typer.echo(f"ogacq: {then}", err=True)
        raise typer.Exit(stop.exit_code) from None
