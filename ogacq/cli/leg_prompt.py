"""The operator of a scripted campaign whose indicators move from leg to leg (the
papers' two): told at each leg's Zero posture where each goes; refused before
anything moves without a terminal to ask on."""

from __future__ import annotations

import sys

from ogacq.campaign.campaign_file import Campaign
from ogacq.cli.plain import shown
from ogacq.cli.render import CampaignProgress, console
from ogacq.errors import InputError
from ogacq.model.gauges import Gauge
from ogacq.protocol.plan import SetGauges
from ogacq.protocol.runner import CampaignStopped, GaugeSetter


def operator_for(campaign: Campaign, progress: CampaignProgress | None = None,
                 ) -> GaugeSetter | None:
    """The set-gauges prompt the campaign needs, or None when its gauges stay put.
    Without ``progress`` it only checks (and refuses) before anything opens."""
    moved = campaign.moved_indicators
    if not moved or campaign.simulator is not None:  # the simulator moves its own
        return None
    if not sys.stdin.isatty():
        where, gauges = next(iter(moved.items()))
        raise InputError(campaign.path, f"the indicator on {where} serves gauges "
                         f"{', '.join(gauges)}: moved from leg to leg, it needs an operator "
                         "at each leg; run this campaign on a terminal, or give each gauge "
                         "its own port or channel")
    return None if progress is None else LegPrompt(campaign, progress)


class LegPrompt:
    """The runner's ``set_gauges``: where each indicator goes, then wait for Enter."""

    def __init__(self, campaign: Campaign, progress: CampaignProgress) -> None:
        self._where = {g.gauge: g.port + (f" channel {g.channel}" if g.channel else "")
                       for g in campaign.gauges}
        self._progress = progress

    def __call__(self, step: SetGauges) -> None:
        with self._progress.paused():
            console.print(f"\n[bold]The machine is at the Zero posture: set the gauges on "
                          f"the {step.leg} leg.[/]")
            for gauge in step.gauges:
                axis = Gauge.parse(gauge).axis
                console.print(f"  along {axis}: the indicator on {shown(self._where[gauge])} "
                              f"(gauge {gauge}), touching the middle of the leg, near "
                              "mid-travel")
            try:
                console.input("Press Enter when both are set and steady (Ctrl-C stops; "
                              "the session can be resumed) ")
            except EOFError:
                raise CampaignStopped(f"the terminal closed while the gauges of the "
                                      f"{step.leg} leg were being set") from None
