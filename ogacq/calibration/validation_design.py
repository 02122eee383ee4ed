"""The scan that validates a scan's maps, grown where a periodic map must be seen.

The validation reads one target between each two of the scan's (``between_plan``): an
aliased map fails there. A periodic map (a screw's cyclic error) is seen by it
directly only over the 16 mm or so that the other legs move its joint; elsewhere it is
seen by its period (``ogacq.calibration.sight``): its pitch, tested on the readings far
from the map's reference, where the joint's own leg sees it through a small
sensitivity. That test's reach falls with the distance from the reference, so the
stretches at the travel's far end are the ones a plain "between" validation misses
(found: the designed scan's 5 mm lead on x, its map right over the whole travel, "not
shown" beyond q = -64 mm, where about twice the readings would have shown it).

So before it runs, the validation's sight of each written periodic map is predicted:
its planned layout read at the scan's measured noise (simulated readings: the sight
depends on the layout and the noise, not on the values read), fitted as the validation
fits, and judged. Where a stretch would not be seen, more targets go into the scan's
gaps there, clear of the scan's own targets and of the "between" ones, while the
plan stays within the budget of machine time.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from ogacq.calibration.sight import PERIODS_SEEN, AxisSight, periodic_modes, sights
from ogacq.calibration.validate import validation_fit
from ogacq.model.axis_map import AxisMap
from ogacq.model.machine import MachineSpec
from ogacq.model.parameters import PARAM_SETS
from ogacq.protocol.plan import ProtocolConfig, planned_layout, reading_steps, scan_targets
from ogacq.protocol.scan_design import between_plan
from ogacq.sim.readings import simulated_readings

# Where in a gap of the scan's targets each growth puts its target: clear of the scan's
# targets (0 and 1), of the between plan's (0.3-0.7) and of the resolving scan's
# (``ogacq.calibration.resolving``, 0.11-0.29). No source: a choice.
GROWTHS = ((0.76, 0.86), (0.02, 0.09), (0.88, 0.97))
# A stretch is taken as seen when what the predicted test would pass there leaves at
# most this share of the correction's size: the readings' own scatter then still
# leaves it seen (no source: a choice).
MARGIN = 0.8
SEED = 1  # the prediction's readings and the growths' jitter: a resume plans the same


def validation_plan(evidence: ProtocolConfig, maps: dict[str, AxisMap],
                    machine: MachineSpec, noise_mm: float,
                    most_steps: int | None = None) -> ProtocolConfig:
    """The validation of ``maps`` identified from the scan ``evidence``: its between
    plan, grown (at most ``most_steps`` reading steps) until the prediction sees every
    stretch of each periodic map."""
    plan = between_plan(evidence, machine)
    periodic = {a: m for a, m in maps.items() if periodic_modes(m) is not None}
    if not periodic:
        return plan
    scanned = np.asarray(scan_targets(evidence, machine), dtype=float)
    rng = np.random.default_rng(SEED)
    # the pitch is read far from a map's reference: there in every growth, beside the
    # stretches not seen
    far = [span for m in periodic.values() for span in far_from(m.reference_mm, scanned)]
    for growth in GROWTHS:
        short = unseen_stretches(plan, periodic, machine, noise_mm)
        if not short:
            break
        added = targets_in_gaps(scanned, growth, rng, short + far)
        grown = replace(plan, scan_targets_mm=tuple(sorted(set(plan.scan_targets_mm)
                                                          | set(added))))
        if not added or (most_steps is not None
                         and len(reading_steps(grown, machine)) > most_steps):
            break
        plan = grown
    return plan


def predicted_sight(plan: ProtocolConfig, maps: dict[str, AxisMap], machine: MachineSpec,
                    noise_mm: float) -> dict[str, AxisSight]:
    """How the validation ``plan`` would see ``maps``, read at ``noise_mm``."""
    layout = planned_layout(plan, machine)
    obs = simulated_readings(machine, layout, {}, scatter_mm=noise_mm,
                             step_mm=machine.gauge_resolution_mm, seed=SEED)
    return sights(maps, *validation_fit(obs, PARAM_SETS["offsets"]), machine)


def unseen_stretches(plan: ProtocolConfig, maps: dict[str, AxisMap],
                     machine: MachineSpec, noise_mm: float) -> list[tuple[float, float]]:
    """The stretches of the travel where the predicted validation would not see a
    periodic map, directly or by its period's reach within ``MARGIN`` (what the
    simulated readings' own test finds of its modes is chance, and left out); none for
    a map it does not see directly over ``PERIODS_SEEN`` periods (more readings far
    off would not show it)."""
    out: set[tuple[float, float]] = set()
    for sight in predicted_sight(plan, maps, machine, noise_mm).values():
        period = sight.period
        if period is None or sight.longest_seen_mm() < PERIODS_SEEN * period.pitch_mm:
            continue  # not seen by its period however many readings are added far off
        by_period = period.reach_mm
        spans = zip(sight.edges_mm[:-1], sight.edges_mm[1:], strict=True)
        for span, direct, leaves in zip(spans, sight.seen_directly, by_period, strict=True):
            if not direct and leaves > MARGIN * sight.correction_mm:
                out.add(span)
    return sorted(out)


# "far from the reference": beyond this share of the farthest target (no source: a
# choice; the outer half holds some 85 % of what the targets tell of a pitch)
FAR = 0.5


def far_from(reference_mm: float, scanned: np.ndarray) -> list[tuple[float, float]]:
    """The spans of the scanned targets' range far from ``reference_mm``."""
    farthest = max(abs(scanned[0] - reference_mm), abs(scanned[-1] - reference_mm))
    return [(float(scanned[0]), reference_mm - FAR * farthest),
            (reference_mm + FAR * farthest, float(scanned[-1]) + 1.0)]


def targets_in_gaps(scanned: np.ndarray, shares: tuple[float, float],
                    rng: np.random.Generator,
                    stretches: list[tuple[float, float]] | None = None) -> list[float]:
    """A target in each gap of the ``scanned`` targets (whose middle lies in one of the
    ``stretches``, where given), at a jittered share of the gap within ``shares``."""
    lo, hi = shares
    out = []
    for left, right in zip(scanned[:-1], scanned[1:], strict=True):
        middle = (left + right) / 2
        if stretches is None or any(a <= middle < b for a, b in stretches):
            share = lo + (hi - lo) * rng.random()
            out.append(float(np.round(left + share * (right - left), 3)))
    return out
