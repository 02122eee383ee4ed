"""A pitch the separating scan leaves unresolved, or too loose for the travel, or a
scan whose fit is not within the noise, read once more at other phases.

The designed scan samples every lead of its band at four phases, but at the noise a
machine shows two pitches can still fit its readings alike: found, a 4.0 mm lead on
z read by the 411-step design at 1.06 µm, "3.99 and 3.854 mm fit alike (chi-square 7.7
apart, under 9)". The maps were then not established and the procedure ended with
the offsets alone, the cyclic error left in place. And a pitch resolved can still be
loose for the travel: a 6.35 mm lead found 6.403 ± 0.043 mm slips its phase by an
eighth of a period over the 100 mm from the map's reference, and its table left
1.1 µm rms of 2.8 (validated: its uncertainty covers it). Both are settled by more
readings at other phases: the scan's gaps read once more (one target in each, at a
jittered 11-19 % of the gap), the gaps far from the map's reference twice (again at
21-29 %: the pitch is read there, in the phase it slips by), where the machine time
allows; the two sessions are then diagnosed together
(``ogacq.calibration.together``). The validation reads between the scan's targets
elsewhere in each gap.
"""

from __future__ import annotations

import numpy as np

from ogacq.calibration.maps import diagnosis_maps
from ogacq.calibration.sight import largest_correction, periodic_modes
from ogacq.calibration.validation_design import far_from, targets_in_gaps
from ogacq.diagnose.diagnosis import Diagnosis
from ogacq.model.machine import MachineSpec
from ogacq.protocol.plan import ProtocolConfig, scan_targets

RESOLVING = "separating-more"  # the campaign's role
# where in a gap, the first in each and the second in the far ones: clear of the scan's
# targets (0, 1), of the validation's between them (0.3-0.7) and of its growth's
# (``validation_design.GROWTHS``). No source: a choice.
SHARES = ((0.11, 0.19), (0.21, 0.29))
SEED = 2  # the jitter: fixed, so that a resumed procedure reads the same
# A periodic map's pitch is loose when its expanded uncertainty (k = 2, the pitch's
# slip included) somewhere on the travel exceeds this share of the correction's size
# (no source: a choice; the table then corrects less than half of it there for sure).
LOOSE = 0.5


def loose_references(diagnosis: Diagnosis, machine: MachineSpec) -> list[float]:
    """The references of the periodic maps whose pitch is loose for the travel."""
    lo, hi = machine.rho_min_mm, machine.rho_max_mm
    out = []
    for m in diagnosis_maps(diagnosis):
        if periodic_modes(m) is None:
            continue
        expanded = 2.0 * max(max(m.u_forward_mm), max(m.u_reverse_mm))
        if expanded > LOOSE * largest_correction(m, lo, hi):
            out.append(m.reference_mm)
    return out


def why_read_more(diagnosis: Diagnosis, machine: MachineSpec,
                  ) -> tuple[str, list[float]] | None:
    """Why the separating scan's gaps are read once more, and the references of the
    loose pitches' maps whose far gaps are read twice; None: nothing to read. A scan
    whose fit is NOT within the gauge noise is read there too: at the 1 % level a
    right model fails once in a hundred scans (seen: a 4 µm lead on z found to 1 %,
    combined p = 0.009, the scan's repeats 10 % quieter than in 14 other runs), and
    its maps were then not established, the run refused; an error the model lacks
    stays in the readings together, judged with more power."""
    if diagnosis.mapped is not None and diagnosis.mapped.search.unresolved:
        return "a pitch is left unresolved", []
    if not diagnosis.final.consistent:
        return "the scan's fit is NOT within the gauge noise", []
    loose = loose_references(diagnosis, machine)
    if loose:
        return ("a pitch is loose for the travel (its map's uncertainty beyond half its "
                "size)", loose)
    return None


def resolving_plan(scan: ProtocolConfig, machine: MachineSpec,
                   references_mm: list[float] | None = None) -> ProtocolConfig:
    """The scan's gaps, one target in each at other phases than the scan read; a second
    in the gaps far from each of ``references_mm`` (a loose pitch's map's)."""
    scanned = np.asarray(scan_targets(scan, machine), dtype=float)
    rng = np.random.default_rng(SEED)
    targets = targets_in_gaps(scanned, SHARES[0], rng)
    for reference in references_mm or ():
        targets += targets_in_gaps(scanned, SHARES[1], rng, far_from(reference, scanned))
    return scan.at_targets(tuple(sorted(set(targets))))
