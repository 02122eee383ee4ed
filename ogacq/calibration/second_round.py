"""A second write round after the validation between the scan's targets showed the maps
wrong.

The separating scan's maps are validated at targets between the scan's
(``scan_design.between_plan``): a map aliased on the scan's targets, or an error
they sampled at one phase, differs there from what it predicts. Where that
validation finds the correction worse (not "not shown": wrong), the first round is
restored, and the scan's readings and the between-targets validation's (denser
together, at irregular intervals) are diagnosed as one (``ogacq.calibration.
together``: each reading where its drive was sent, in the scan's frame of offsets,
which the restore put back). The compensation of that diagnosis is written once more,
as the first (shown, confirmed, read back, audited), and validated once more: at the
papers' postures, and between the targets the second diagnosis read (positions
neither round was identified from, as many as the first validation's). At most one
extra round, and only where its measurement fits the time budget of the separating
scan (``--scan-minutes``): the second validation's scan, at this machine's time per
reading step.

Not taken (and said why) where the scan ran with maps applied (its readings then hold
the machine's error less those maps, the readings together its whole error: one
compensation cannot stand on both), where the readings together do not establish
maps either (``separate.not_established``), or beyond the budget.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ogacq.calibration.compensate import Compensation
from ogacq.calibration.separate import seconds_per_step, steps_of
from ogacq.calibration.validate import Judgement
from ogacq.campaign.run import recorded_maps
from ogacq.model.machine import MachineSpec
from ogacq.protocol.plan import ProtocolConfig, scan_targets
from ogacq.protocol.scan_design import between_plan
from ogacq.session.store import LoadedSession
from ogacq.writeback.maps_table import maps_checksum

ROUND = 2  # the log's ``round`` of the second round's steps; the first's carry none
# the role of the diagnosis of the scan and its validation ("diagnosis of the ... campaign")
TOGETHER = "separating + validation-scan"
VALIDATION = "validation-2"
VALIDATION_SCAN = "validation-scan-2"


@dataclass(frozen=True)
class RoundDone:
    """One write round's end: what it wrote, how its validation judged it, what was
    restored (each write's and restore's operation, None where none)."""

    comp: Compensation
    validation: LoadedSession
    judgement: Judgement
    written: dict[str, str | None]
    restored: dict[str, str | None]
    between: Judgement | None = None  # the validation between the evidence's targets
    between_session: LoadedSession | None = None


def together_protocol(scan: ProtocolConfig, between: ProtocolConfig,
                      machine: MachineSpec) -> ProtocolConfig:
    """The scan whose targets are both the scan's and its validation's: what the second
    diagnosis read (its pitch band), and whose between-targets scan validates it."""
    targets = sorted({round(t, 6) for p in (scan, between) for t in scan_targets(p, machine)})
    return scan.at_targets(tuple(targets))


def second_validation(together: ProtocolConfig, machine: MachineSpec) -> ProtocolConfig:
    """The second round's scan validation: between the targets of both sessions, every
    other one (as many as the first validation's, about the scan's machine time: a
    designed scan fills the budget, and a validation of twice its targets would leave
    no second round within it)."""
    between = between_plan(together, machine)
    return replace(between, scan_targets_mm=between.scan_targets_mm[::2])


def why_not(scan: LoadedSession, validation: ProtocolConfig, machine: MachineSpec,
            rate_from: LoadedSession, budget_s: float) -> str:
    """Why the second round is not taken (empty: it is)."""
    recorded = recorded_maps(scan)
    if recorded and recorded.get("checksum") not in (None, maps_checksum({})):
        return ("no second round: the separating scan ran with maps applied, so its "
                "readings and the validation's cannot be fitted as one machine error")
    duration = steps_of(validation, machine) * seconds_per_step(rate_from)
    if not np.isfinite(duration) or duration > budget_s:
        return (f"no second round: its validation scan would take about "
                f"{duration / 60:.0f} min of machine time, beyond the "
                f"{budget_s / 60:.0f} min the separating scan may take (--scan-minutes)")
    return ""
