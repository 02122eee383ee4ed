"""``ogacq run`` and ``ogacq resume``: campaigns from the command line, and the
progress and result display ``ogacq demo`` shares with them."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path
from typing import Annotated

import typer

from ogacq.campaign import CampaignOutcome, resumable_campaign, run_campaign
from ogacq.campaign_file import read_campaign
from ogacq.cli.history_record import record_campaign
from ogacq.cli.leg_prompt import operator_for
from ogacq.cli.options import HistoryOption, JsonOption, OverrideExpiredOption, override_reason
from ogacq.cli.render import CampaignProgress, campaign_progress, print_outcome
from ogacq.protocol.runner import CampaignStopped
from ogacq.session.store import load_session


def run(
    campaign_file: Annotated[Path, typer.Argument(help="Campaign file (TOML).")],
    as_json: JsonOption = False,
    history: HistoryOption = None,
    override_expired: OverrideExpiredOption = None,
) -> None:
    """Run a scripted campaign: no operator when the six gauges are mounted, or one
    asked to set them at each leg when indicators move from leg to leg."""
    reason = override_reason(override_expired)
    campaign = read_campaign(campaign_file)
    if reason:
        campaign.override_expired = reason
    operator_for(campaign)  # refuses, before anything opens, one that needs an operator
    outcome = execute(lambda obs: run_campaign(
        campaign, observer=obs, set_gauges=operator_for(campaign, obs)), campaign.session,
        quiet=as_json)
    show_outcome(outcome, as_json)
    record_campaign(outcome.session_path, history)


def resume(
    session: Annotated[Path, typer.Argument(help="Session file of an interrupted campaign.")],
    as_json: JsonOption = False,
    history: HistoryOption = None,
    override_expired: OverrideExpiredOption = None,
) -> None:
    """Continue an interrupted campaign where it stopped."""
    reason = override_reason(override_expired)
    loaded = load_session(session)
    campaign = resumable_campaign(loaded)
    if reason:
        campaign.override_expired = reason
    operator_for(campaign)  # refuses, before anything opens, one that needs an operator
    outcome = execute(lambda obs: run_campaign(
        campaign, resume=loaded, observer=obs, set_gauges=operator_for(campaign, obs)),
        loaded.path, quiet=as_json)
    show_outcome(outcome, as_json)
    record_campaign(outcome.session_path, history)


def execute(start: Callable[[CampaignProgress], CampaignOutcome], session: Path, *,
            quiet: bool = False) -> CampaignOutcome:
    """Run ``start(observer)`` with progress shown; a stop exits non-zero with its reason
    and the command that continues ``session``."""
    with campaign_progress(enabled=not quiet) as observer:
        try:
            return start(observer)
        except CampaignStopped as stop:
            typer.echo(f"ogacq: campaign {stop.status}: {stop.reason}", err=True)
            typer.echo(f"ogacq: the session is saved: continue it with `ogacq resume "
                       f"{session}`", err=True)
            raise typer.Exit(stop.exit_code) from None


def show_outcome(outcome: CampaignOutcome, as_json: bool) -> None:
    if as_json:
        typer.echo(json.dumps({"session": str(outcome.session_path),
                               **outcome.fit.to_json("offsets"),
                               "hidden": outcome.hidden, "simulated": outcome.simulated}))
        return
    print_outcome(outcome)
