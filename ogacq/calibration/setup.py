"""Where a calibration procedure runs: its folder, machine, campaigns and files.

On the built-in simulator (``ogacq calibrate --simulator``) the folder gets the
machine file, the effects file and one campaign file per campaign, as ``ogacq
demo`` writes them, and one simulator serves the whole procedure (its drives keep
what is written to them between campaigns). On a station, the campaign file names
the controller and the gauges; each campaign of the procedure is that campaign
with its own plan and its own session in the folder. Either way the maps ogacq
applies are the controller's ``maps_file`` (in the folder on the simulator), and
profiles without an offset register keep their offsets in ``offsets_file``.
"""

from __future__ import annotations

import datetime
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from ogacq_drivers.axes.profile import load_profile
from ogacq.campaign.campaign_file import (
    AxisScaleSpec,
    Campaign,
    ControllerSpec,
    SimulatorSpec,
    campaign_text,
)
from ogacq.campaign.traceability import simulated_gauges
from ogacq.io.atomic import write_atomically
from ogacq.model.machine import MachineSpec
from ogacq.protocol.plan import ProtocolConfig
from ogacq.protocol.positioning import ISO_RUNS

MAPS_FILE = "maps.json"
OFFSETS_FILE = "offsets.toml"
# The scan a suspected map gets with --scan-step-mm: every step, both directions, two
# cycles (ISO 230-2's bidirectional cycle, shortened from its five): with repeats, the
# gauge noise is measured rather than assumed from the display step, which with one
# cycle made the test conservative enough to miss an encoder scale beside a backlash.
# Without it the scan is designed (ogacq.protocol.scan_design).
SCAN_CYCLES = 2
# The machine time a designed separating scan may take: the three legs' scan of every
# lead from 2 to 40 mm at 4 phases, about 410 reading steps at 5.5 s a step (no
# source: a shift's break; --scan-minutes and the campaign file's scan_minutes set it).
SCAN_MINUTES = 40.0


@dataclass(frozen=True)
class Setup:
    folder: Path
    machine: MachineSpec
    machine_path: Path
    protocol: ProtocolConfig  # of the calibration campaign
    controller: ControllerSpec  # its files; its endpoints the simulator's when simulated
    gauges: tuple = ()
    simulator: SimulatorSpec | None = None
    operator: str = ""
    environment: Any = None
    override_expired: str = ""
    campaign_path: Path | None = None  # the station's campaign file
    scan_step_mm: float | None = None  # None: the separating scan is designed
    separate: bool = True  # run the separating measurement when ambiguous
    # the designed scan's machine time budget given (--scan-minutes, the campaign file):
    # the scan then grows within it toward its detection target; None: SCAN_MINUTES,
    # and the scan the fewest targets that sample its band
    scan_minutes: float | None = None
    # scales along the actuators: the maps written on their axes are validated by
    # ISO 230-2's positioning test (ogacq.calibration.scale_check), in this many runs
    axis_scales: dict[str, AxisScaleSpec] = field(default_factory=dict)
    scale_runs: int = ISO_RUNS

    @property
    def scan_budget_s(self) -> float:
        return (self.scan_minutes or SCAN_MINUTES) * 60.0

    @property
    def simulated(self) -> bool:
        return self.simulator is not None

    def campaign(self, role: str, protocol: ProtocolConfig) -> Campaign:
        """The campaign of one step of the procedure (``calibration``, ``separating``,
        ``validation``), its session ``ROLE.jsonl`` in the folder; on the simulator its
        file ``ROLE.toml`` is written there for the record."""
        session = self.folder / f"{role}.jsonl"
        path = self.campaign_path or self.folder / f"{role}.toml"
        campaign = Campaign(path, self.machine, self.machine_path, session, protocol,
                            controller=self.controller, gauges=list(self.gauges),
                            simulator=self.simulator, operator=self.operator,
                            environment=self.environment,
                            override_expired=self.override_expired,
                            axis_scales=dict(self.axis_scales))
        if self.campaign_path is None and not path.exists():
            write_atomically(path, campaign_text(
                replace(campaign, controller=None),
                comment=f"written by `ogacq calibrate`: its {role} campaign. The procedure "
                        f"applies the maps in {MAPS_FILE} to every target (resume it with "
                        "`ogacq calibrate --resume`, which applies them)").encode("utf-8"))
        return campaign

    def scan_protocol(self) -> ProtocolConfig:
        """A scan of every leg's travel, both directions (the separating measurement
        where a map is suspected)."""
        return replace(self.protocol, scan_step_mm=self.scan_step_mm or 1.0,
                       approach="both", cycles=SCAN_CYCLES, postures=(),
                       scan_targets_mm=())

    def describe(self) -> dict[str, Any]:
        """What the log's header records of the setup."""
        return {"folder": str(self.folder.resolve()), "mode": "simulator" if self.simulated
                else "station", "machine_file": str(self.machine_path),
                "campaign_file": str(self.campaign_path) if self.campaign_path else None,
                "simulator": self.simulator.header() if self.simulator else None,
                "maps_file": str(self.controller.maps_file) if self.controller.maps_file
                else None,
                "offsets_file": str(self.controller.offsets_file)
                if self.controller.offsets_file else None,
                "plan": self.protocol.to_dict(), "scan_step_mm": self.scan_step_mm,
                "scan_minutes": self.scan_minutes, "separate": self.separate,
                "operator": self.operator,
                "override_expired": self.override_expired,
                **({"axis_scales": sorted(self.axis_scales), "scale_runs": self.scale_runs}
                   if self.axis_scales else {})}


def simulator_controller(folder: Path, profile: str) -> ControllerSpec:
    """The simulated controller's files: the maps ogacq applies, and the software
    offset table where the profile has no offset register."""
    software = load_profile(profile).offset.kind == "software"
    return ControllerSpec(profile, maps_file=(folder / MAPS_FILE).resolve(),
                          offsets_file=(folder / OFFSETS_FILE).resolve() if software else None)


def simulator_setup(folder: Path, machine: MachineSpec, machine_path: Path,
                    simulator: SimulatorSpec, *, operator: str, override_expired: str = "",
                    scan_step_mm: float | None = None, separate: bool = True,
                    scan_minutes: float | None = None,
                    today: datetime.date | None = None, scale_runs: int = ISO_RUNS) -> Setup:
    """``simulator.axis_scales``: the axes the simulator serves a scale along."""
    scales = {a: AxisScaleSpec(resolution_mm=simulator.scale_resolution_mm)
              for a in simulator.axis_scales}
    return Setup(folder, machine, machine_path, ProtocolConfig(settle_s=1.0),
                 simulator_controller(folder, simulator.profile),
                 tuple(simulated_gauges(today or datetime.date.today())), simulator,
                 operator=operator, override_expired=override_expired,
                 scan_step_mm=scan_step_mm, separate=separate, scan_minutes=scan_minutes,
                 axis_scales=scales, scale_runs=scale_runs)


def station_setup(folder: Path, campaign: Campaign, *, scan_step_mm: float | None = None,
                  separate: bool = True, scan_minutes: float | None = None,
                  scale_runs: int = ISO_RUNS) -> Setup:
    assert campaign.controller is not None
    return Setup(folder, campaign.machine, campaign.machine_path, campaign.protocol,
                 campaign.controller, tuple(campaign.gauges), None, campaign.operator,
                 campaign.environment, campaign.override_expired, campaign.path,
                 scan_step_mm, separate, scan_minutes=scan_minutes,
                 axis_scales=dict(campaign.axis_scales), scale_runs=scale_runs)
