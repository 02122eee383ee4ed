"""A pitch the separating scan leaves unresolved, read once more at other phases.

The designed scan samples every lead of its band at four phases, but at the noise a
machine shows two pitches can still fit its readings alike: found, a 4.0 mm lead on
z read by the 411-step design at 1.06 µm, "3.99 and 3.854 mm fit alike (chi-square 7.7
apart, under 9)". The maps were then not established and the procedure ended with
the offsets alone, the cyclic error left in place. Both pitches predict the same
readings at the scan's targets and differ between them, so the scan's gaps are read
once more (one target in each, at a jittered 12-26 % of the gap: clear of the scan's
own targets and of the validation's), where the machine time allows, and the two
sessions are diagnosed together (``ogacq.calibration.together``).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from ogacq.calibration.validation_design import targets_in_gaps
from ogacq.diagnose.diagnosis import Diagnosis
from ogacq.model.machine import MachineSpec
from ogacq.protocol.plan import ProtocolConfig, scan_targets

RESOLVING = "separating-more"  # the campaign's role
SHARES = (0.12, 0.26)  # where in each gap (no source: a choice, see the docstring)
SEED = 2  # the jitter: fixed, so that a resumed procedure reads the same


def unresolved(diagnosis: Diagnosis) -> bool:
    """A cyclic error beyond the noise whose pitch another fits alike."""
    return diagnosis.mapped is not None and bool(diagnosis.mapped.search.unresolved)


def resolving_plan(scan: ProtocolConfig, machine: MachineSpec) -> ProtocolConfig:
    """The scan's gaps, one target in each at other phases than the scan read."""
    scanned = np.asarray(scan_targets(scan, machine), dtype=float)
    targets = targets_in_gaps(scanned, SHARES, np.random.default_rng(SEED))
    return replace(scan, scan_step_mm=None, scan_from_mm=None, scan_to_mm=None,
                   scan_targets_mm=tuple(targets))
