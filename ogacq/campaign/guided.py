"""Running the wizard's campaign: the same plan, the same runner, the same
session format as ``ogacq run``; and the campaign file written beside the
session so ``ogacq resume`` can continue it.

``run_guided`` is ``ogacq.campaign.run.run_campaign`` with the opened station
wrapped (checkpoints for Ctrl-C, gauges read by eye, live values).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ogacq.campaign.campaign_file import (
    Campaign,
    ControllerSpec,
    GaugeSpec,
    SimulatorSpec,
    campaign_text,
)
from ogacq.campaign.run import CampaignOutcome, EnvironmentAsker, StationAdapter, run_campaign
from ogacq.campaign.station import simulator_endpoints, start_simulator
from ogacq.io.atomic import write_atomically
from ogacq.model.gauges import Gauge
from ogacq.protocol.runner import GaugeSetter, Observer
from ogacq.session.store import LoadedSession

if TYPE_CHECKING:
    from ogacq.sim.stack import SimulatorStack


@dataclass(frozen=True)
class Rehearsal:
    """The built-in simulator the wizard started, and how to start it again."""

    spec: SimulatorSpec
    stack: SimulatorStack
    controller: ControllerSpec
    gauges: list[GaugeSpec]

    def shown_value(self, gauge: str) -> float:
        """What a simulated dial shows now, at the machine's resolution."""
        axis, leg = Gauge.parse(gauge).indices
        resolution = self.stack.machine.machine.gauge_resolution_mm
        value = self.stack.machine.gauge_value_mm(axis, leg)
        return round(value / resolution) * resolution


def start_rehearsal(campaign: Campaign, spec: SimulatorSpec) -> Rehearsal:
    """Start the simulator exactly as a ``[simulator]`` campaign would, so that
    ``ogacq resume`` on the written campaign file meets the same hidden machine."""
    stack = start_simulator(campaign.machine, spec)
    controller, gauges = simulator_endpoints(stack)
    return Rehearsal(spec, stack, controller, gauges)


def run_guided(campaign: Campaign, *, wrap: StationAdapter, observer: Observer,
               set_gauges: GaugeSetter, resume: LoadedSession | None,
               wizard_header: dict[str, Any], rehearsal: Rehearsal | None,
               environment_at_end: EnvironmentAsker | None = None) -> CampaignOutcome:
    """``run_campaign`` with the opened station wrapped and, for a rehearsal, on the
    simulator the wizard already started."""
    if rehearsal is not None:
        campaign.simulator = rehearsal.spec  # recorded in the header as [simulator] is
    return run_campaign(campaign, observer=observer, set_gauges=set_gauges, resume=resume,
                        simulator=rehearsal.stack if rehearsal is not None else None,
                        wrap_station=wrap, header_extra={"wizard": wizard_header},
                        environment_at_end=environment_at_end)


# ---------------------------------------------------------------- the campaign file

def campaign_file_text(campaign: Campaign, by_eye: set[str], rehearsal: Rehearsal | None,
                       purpose: str = "") -> str:
    """The campaign file (``ogacq/campaign/campaign_file.py``) for what the technician chose."""
    purpose = purpose or ("continue an interrupted campaign with: ogacq resume "
                          f"{_relative(campaign.session, Path.cwd())}")
    notes = {}
    if rehearsal is not None:
        campaign = replace(campaign, simulator=rehearsal.spec, controller=None, gauges=[])
        notes["simulator"] = (
            "a rehearsal on the built-in simulator (ports of this run: controller "
            f"{rehearsal.controller.endpoints()}; gauges "
            + ", ".join(f"{g.gauge} {g.port}" for g in rehearsal.gauges) + ")")
    if by_eye:
        notes["protocol"] = (f"read by eye in the wizard (no [[gauges]] entry): "
                             f"{', '.join(sorted(by_eye))}; continue with `ogacq wizard "
                             "--resume`")
    return campaign_text(campaign, notes=notes, comment=(
        f"written by `ogacq wizard` on {time.strftime('%Y-%m-%d %H:%M')}\n{purpose}"))


def _relative(path: Path, folder: Path) -> str:
    try:
        return str(path.resolve().relative_to(folder.resolve()))
    except ValueError:
        return str(path.resolve())


def rehearsal_controller_file(campaign: Campaign, rehearsal: Rehearsal) -> Path:
    """A campaign file naming the live rehearsal simulator's endpoints, for commands
    run while the wizard holds it open (``ogacq offsets write --campaign``)."""
    path = campaign.path.with_name("rehearsal-controller.toml")
    live = Campaign(path, campaign.machine, campaign.machine_path, campaign.session,
                    campaign.protocol, rehearsal.controller, list(rehearsal.gauges))
    write_atomically(path, campaign_file_text(
        live, set(), None, "the rehearsal simulator's endpoints: valid only while the "
                           "wizard that started it runs").encode("utf-8"))
    return path
