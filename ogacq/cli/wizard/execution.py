"""Running the wizard's campaign: the same plan, the same runner, the same
session format as ``ogacq run``; and the campaign file written beside the
session so ``ogacq resume`` can continue it.

``run_guided`` is ``ogacq.campaign.run_campaign`` with the opened station
wrapped (checkpoints for Ctrl-C, gauges read by eye, live values).
"""

from __future__ import annotations

import json
import time
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ogacq.campaign import CampaignOutcome, StationWrapper, run_campaign
from ogacq.campaign_file import Campaign, ControllerSpec, GaugeSpec, SimulatorSpec
from ogacq.protocol.plan import ProtocolConfig
from ogacq.protocol.runner import GaugeSetter, Observer
from ogacq.session.store import LoadedSession
from ogacq.station import simulator_endpoints, start_simulator

if TYPE_CHECKING:
    from ogacq.sim.stack import SimulatorStack


@dataclass(frozen=True)
class Rehearsal:
    """The built-in simulator the wizard started, and how to start it again."""

    spec: SimulatorSpec
    stack: SimulatorStack
    controller: ControllerSpec
    gauges: list[GaugeSpec]

    def header(self) -> dict[str, Any]:
        return self.spec.header()

    def hidden(self) -> dict[str, float]:
        return self.stack.machine.truth.hidden()

    def shown_value(self, gauge: str) -> float:
        """What a simulated dial shows now, at the machine's resolution."""
        from ogacq.cli.wizard.expected import gauge_axes

        axis, leg = gauge_axes(gauge)
        resolution = self.stack.machine.machine.gauge_resolution_mm
        value = self.stack.machine.gauge_value_mm(axis, leg)
        return round(value / resolution) * resolution


def start_rehearsal(campaign: Campaign, spec: SimulatorSpec) -> Rehearsal:
    """Start the simulator exactly as a ``[simulator]`` campaign would, so that
    ``ogacq resume`` on the written campaign file meets the same hidden machine."""
    stack = start_simulator(campaign.machine, spec)
    controller, gauges = simulator_endpoints(stack)
    return Rehearsal(spec, stack, controller, gauges)


def run_guided(campaign: Campaign, *, wrap: StationWrapper, observer: Observer,
               set_gauges: GaugeSetter, resume: LoadedSession | None,
               wizard_header: dict[str, Any], rehearsal: Rehearsal | None,
               ) -> CampaignOutcome:
    """``run_campaign`` with the opened station wrapped and, for a rehearsal, on the
    simulator the wizard already started."""
    if rehearsal is not None:
        campaign.simulator = rehearsal.spec  # recorded in the header as [simulator] is
    return run_campaign(campaign, observer=observer, set_gauges=set_gauges, resume=resume,
                        simulator=rehearsal.stack if rehearsal is not None else None,
                        wrap_station=wrap, header_extra={"wizard": wizard_header})


# ---------------------------------------------------------------- the campaign file

def _toml(value: Any) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return json.dumps(value)  # a TOML basic string is a JSON string
    if isinstance(value, list | tuple):
        return "[" + ", ".join(_toml(v) for v in value) + "]"
    return repr(value)


def _relative(path: Path, folder: Path) -> str:
    try:
        return str(path.resolve().relative_to(folder.resolve()))
    except ValueError:
        return str(path.resolve())


def campaign_file_text(campaign: Campaign, by_eye: set[str], rehearsal: Rehearsal | None,
                       purpose: str = "") -> str:
    """The TOML of ``ogacq/campaign_file.py`` for what the technician chose."""
    folder = campaign.path.parent
    purpose = purpose or ("continue an interrupted campaign with: ogacq resume "
                          f"{_relative(campaign.session, Path.cwd())}")
    lines = [f"# written by `ogacq wizard` on {time.strftime('%Y-%m-%d %H:%M')}",
             f"# {purpose}",
             f"machine = {_toml(_relative(campaign.machine_path, folder))}",
             f"session = {_toml(_relative(campaign.session, folder))}", ""]
    if rehearsal is not None:
        lines += ["# a rehearsal on the built-in simulator (ports of this run: controller "
                  f"{rehearsal.controller.endpoints()}; gauges "
                  + ", ".join(f"{g.gauge} {g.port}" for g in rehearsal.gauges) + ")",
                  "[simulator]"]
        lines += [f"{k} = {_toml(v)}" for k, v in (("seed", rehearsal.spec.seed),
                                                   ("speed", rehearsal.spec.speed),
                                                   ("profile", rehearsal.spec.profile))]
        if rehearsal.spec.effects:
            lines.append(f"effects = {_toml(str(rehearsal.spec.effects))}")
        if rehearsal.spec.gauge_layout != "separate":
            lines.append(f"gauge_layout = {_toml(rehearsal.spec.gauge_layout)}")
        lines.append("")
    else:
        assert campaign.controller is not None
        spec = campaign.controller
        lines += ["[controller]", f"profile = {_toml(spec.profile)}"]
        if spec.port:
            lines.append(f"port = {_toml(spec.port)}")
        if spec.axes:  # one endpoint per axis (a drive per address)
            lines.append("[controller.axes]")
            for axis, endpoint in spec.axes.items():
                fields = ([f"port = {_toml(endpoint.port)}"] if endpoint.port else []) + \
                    ([f"device_id = {endpoint.device_id}"] if endpoint.device_id is not None
                     else [])
                lines.append(f"{axis} = {{ {', '.join(fields)} }}")
        lines.append("")
        for gauge in campaign.gauges:
            lines += ["[[gauges]]", f"gauge = {_toml(gauge.gauge)}",
                      f"protocol = {_toml(gauge.protocol)}", f"port = {_toml(gauge.port)}",
                      f"unit = {_toml(gauge.unit)}", ""]
    if by_eye:
        lines += [f"# read by eye in the wizard (no [[gauges]] entry): "
                  f"{', '.join(sorted(by_eye))}; continue with `ogacq wizard --resume`", ""]
    plan = campaign.protocol.to_dict()
    stability = plan.pop("stability")
    lines += ["[protocol]", *(f"{k} = {_toml(v)}" for k, v in plan.items()), "",
              "[stability]", *(f"{k} = {_toml(v)}" for k, v in stability.items()), ""]
    return "\n".join(lines)


def rehearsal_controller_file(campaign: Campaign, rehearsal: Rehearsal) -> Path:
    """A campaign file naming the live rehearsal simulator's endpoints, for commands
    run while the wizard holds it open (``ogacq offsets write --campaign``)."""
    path = campaign.path.with_name("rehearsal-controller.toml")
    live = Campaign(path, campaign.machine, campaign.machine_path, campaign.session,
                    campaign.protocol, rehearsal.controller, list(rehearsal.gauges))
    path.write_text(campaign_file_text(
        live, set(), None, "the rehearsal simulator's endpoints: valid only while the "
                           "wizard that started it runs"))
    return path


def protocol_round_trips(path: Path, protocol: ProtocolConfig) -> bool:
    """Whether the written file gives back the same plan (``ogacq resume`` requires it)."""
    from ogacq.campaign_file import read_campaign
    from ogacq.io.errors import InputError

    try:
        return read_campaign(path).protocol.to_dict() == protocol.to_dict()
    except InputError:
        return False
