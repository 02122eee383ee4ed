"""The separating scan designed for the machine: where each leg is read, and what that
can and cannot see, before anything moves.

A scan every ``d`` mm samples an error of period ``P`` at the phases ``k d / P``: a
lead that is a whole multiple of ``d`` (a 5 mm lead on a 5 mm scan) is read at one
phase and passes for an offset; a lead near ``2 d`` at two, where it cannot be told
from its aliases. ISO 230-2:2014 4.3.2 therefore sets a test's target positions at
irregular intervals, "to ensure that periodic errors are adequately sampled". The
design here does so for every period a drive can have:

* each leg's travel is cut into ``n`` equal strata, its two ends are targets and
  each stratum between holds one, jittered within it (stratified sampling, whose
  spectral window has no alias at the strata's spacing: Cook, "Stochastic sampling
  in computer graphics", ACM ToG 5, 1986; the same idea as ISO 230-2's irregular
  targets); the jitter of several seeds is tried and the one whose phases are best
  spread is kept (deterministic: the same machine gets the same design);
* a period is *sampled* when the targets' phases modulo it leave no gap wider than a
  quarter of it (at least ``MIN_PHASES`` phases, none of its quarters missed):
  checked numerically for every period of the band, on a frequency grid fine enough
  that no phase moves by more than ``PHASE_GRID`` of a period between grid points;
* the band is every stated drive period (a screw's lead, a motor revolution, from the
  machine file) and its second harmonic, and every period from 2 to 40 mm where an
  axis states none (``UNSTATED_BAND_MM``: miniature to high-helix ball screws of a
  machine this size), else from the shortest stated one (the search's 1 mm at least):
  continuous in both cases, since the diagnosis searches a band of pitches;
* the targets are read up and back down from beyond each end (ISO 230-2 4.3's
  bidirectional cycle: both sides where a lost motion or hysteresis may be, the
  whole travel between reversals for a wind-up), two cycles (the repeats measure the
  gauge noise the verdict needs);
* ``n`` is the fewest that sample the band, within the time budget; a budget too
  small for it gives the most the budget allows, and what that leaves unsampled is
  said; more where that reaches ``DETECTION_TARGET_MM`` in every family within the
  budget, else what would is said.

The detection limit of each family is ``DETECTION_SIGMAS`` times the std of its
amplitude at the gauge noise, from the design's normal matrix: each family's columns
(``ogacq.model.error_maps``) through the joint sensitivities of the planned readings,
less what the joint offsets and each gauge's zero take (``C' (I - P_B) C``; the
diagnosis fits both), the readings weighed by the diagnosis's own covariance
(``identify.noise``): the part of the display's rounding
that the gauge's scatter does not dither away is shared by a posture's repeats, so on
a 10 um display the cycles of a posture count about once. A smooth map's constant is
its joint offset's and its slope its axis's encoder scale's, exactly: its limit is
stated for the rest, the map less its straight line over the travel, as the rms of the
least visible such shape (the smallest generalised eigenvalue of the normal matrix
against the maps' rms over the travel), one shape as the other families' one
amplitude.

That limit is set by the sensitivity and by where the targets are: a leg's gauges read
across its own axis, so its joint's error reaches them only through the legs' tilt (at
most 0.13 of it on the built-in machine, none near the Zero posture), the other legs'
scans move it over a sixth of its travel only, and there each gauge's zero takes its
constant. Within a budget the strata are therefore cut partly by where the map is
seen (:class:`SmoothAllocation`, the E-optimal allocation of its information over
candidate targets), as long as every period stays sampled: on the built-in machine at
a 0.5 um gauge, 34 targets go from 2.35 um in equal strata to 1.87 um, and no placing
of them goes below 1.76 um (of 37 targets, 447 steps: 1.68 um), so that 1.5 um takes
675 steps. Where a budget falls short of ``DETECTION_TARGET_MM`` the design says what
would reach it and that bound (the allocation's dual).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field, replace
from functools import lru_cache
from typing import Any

import numpy as np

from ogacq.identify.noise import GaugeNoise, GroupWhitener, shared_rounding_variance
from ogacq.identify.observations import Observations
from ogacq.identify.search_rules import (
    FOUND_SHARE,
    LEVEL,
    OVERSAMPLE,
    SHORTEST_LEAD_MM,
    chi2_threshold,
    found_noncentrality,
    local_maxima,
    resolved_noncentrality,
)
from ogacq.model.error_maps import JointHistory, MapTerm
from ogacq.model.families import FAMILIES
from ogacq.model.joint_sensitivity import joint_sensitivity
from ogacq.model.machine import MachineSpec
from ogacq.model.measurement import ReadingsLayout
from ogacq.model.parameters import AXES, vector
from ogacq.model.units import UM_PER_MM
from ogacq.protocol.plan import ProtocolConfig, planned_layout, reading_steps, scan_targets

Strata = tuple[np.ndarray, np.ndarray]  # (cumulative share, position) along the travel
MIN_PHASES = 4
LARGEST_PHASE_GAP = 1.0 / MIN_PHASES  # of a period
# Every lead of a ball screw on a machine of this size, when the file states none:
# miniature screws from 2 mm, high-helix ones to 40 mm (THK "Ball Screw" catalogue,
# lead tables A15); a longer period over a travel of a few hundred mm is a smooth map.
UNSTATED_BAND_MM = (2.0, 40.0)
# A period must repeat this many times over the travel to be a cyclic error rather
# than a smooth map (the diagnosis's own bound: mapsearch.MIN_PERIODS).
PERIODS_OVER_TRAVEL = 3.0
HARMONICS = (1, 2)  # a screw's lead and its second harmonic (an eccentric nut: twice)
PHASE_GRID = 0.002  # of a period: the coverage grid's resolution
SEARCH_GRID = 0.01  # coarser while the jitters are compared; the one kept is checked finely
DESIGN_CYCLES = 2  # the repeats measure the gauge noise
# No source beyond the counts: from a handful of strata to a step of a few tenths.
FEWEST_POSITIONS = 12
MOST_POSITIONS = 1000
SEEDS = 16  # jitters tried per count of positions
# No source: an alias at most half the size of a lead's own peak, which a periodogram
# then cannot prefer while the noise's share of either is small.
ALIAS_LIMIT = 0.5
DETECTION_SIGMAS = 3.0
# The limit a design grows its targets toward, within the budget (issue 37's target at
# a 0.5 um gauge; no standard source): a design that cannot reach it says what would.
DETECTION_TARGET_MM = 0.0015
# Another jitter of more targets sees a little less than the square root promises (the
# built-in machine: 61 targets predicted from 34 gave 1.54 um; 65 gave 1.46).
TARGETS_MARGIN = 1.05
SMOOTH_KNOTS = 8  # the smooth map whose detection is stated (a cubic spline)
BUILD_UP_MM = 4.0  # the wind-up whose detection is stated
# Where the smooth map is seen: the candidates its allocation is solved on (a target's
# information changes little over a millimetre), the shares of the strata cut equal in
# that allocation's weight rather than in length that are tried (the rest keeps every
# period's phases spread), and each candidate's weight spread over a target's jitter.
# No source beyond the built-in machine, where they bring the 40-minute design's 34
# targets from 2.35 to 1.87 um (the cyclic limit from 0.77 to 0.80 um), every phase
# bound kept; no placing of 34 targets goes below 1.76 um (the allocation's bound).
CANDIDATE_STEP_MM = 1.0
INFORMED_SHARES = (0.5, 0.7, 0.85, 1.0)
SPREAD_MM = 2.0
ALLOCATION_ROUNDS = 300
ALLOCATION_GAP = 0.02  # the dual bound within 2 % of the allocation's own limit: done
SOFT_MIN = 30.0  # eigenvalues 10 % above the least weigh e^-3 of it in the soft minimum


@dataclass(frozen=True)
class ScanDesign:
    """A designed separating scan and what it resolves."""

    protocol: ProtocolConfig
    steps: int  # reading steps, every leg
    seconds_per_step: float  # this machine's, measured (0: not known)
    budget_s: float | None  # the time allowed (None: none)
    # the band asked for: 2-40 mm, or from the shortest stated period where all are stated
    required_mm: tuple[float, float]
    stated_mm: tuple[float, ...]  # stated periods and their harmonics, to sample
    pitch_band_mm: tuple[float, float]  # every period in it sampled at >= MIN_PHASES
    unsampled_mm: tuple[float, ...]  # stated periods the design misses (budget short)
    worst_gap: float  # the largest phase gap over the band and the stated, of a period
    noise_mm: float
    detection_mm: dict[str, float]  # family -> DETECTION_SIGMAS x its amplitude's std
    alias_level: float = 0.0  # the spectral window's largest sidelobe (alias_level)
    target_steps: int = 0  # the reading steps DETECTION_TARGET_MM would need (0: reached)
    # the least smooth-map limit any placing of these targets reaches (0: not asked)
    smooth_bound_mm: float = 0.0
    display_step_mm: float = 0.0
    rounding_repeated: bool = False  # most of a reading's noise its repeats share
    # family -> the size the map search takes at FOUND_SHARE (cyclic_found_mm)
    found_mm: dict[str, float] = field(default_factory=dict)

    @property
    def targets_mm(self) -> tuple[float, ...]:
        return self.protocol.scan_targets_mm

    @property
    def duration_s(self) -> float:
        return self.steps * self.seconds_per_step

    @property
    def complete(self) -> bool:
        """Samples all it was asked to (the band and every stated period)."""
        return not self.unsampled_mm and self.band_covered

    @property
    def band_covered(self) -> bool:
        return (self.pitch_band_mm[0] <= self.required_mm[0] + 1e-9
                and self.pitch_band_mm[1] >= self.required_mm[1] - 1e-9)

    def may_remain(self) -> str:
        """What a scan that found no map leaves possible, in words ("" where the design
        states no size its search finds)."""
        found = self.found_mm.get("lead_screw_cyclic")
        if found is None or not math.isfinite(found):
            return ""
        return (f"the separating scan finds a cyclic error of about "
                f"{found * UM_PER_MM:.2g} µm or more ({FOUND_SHARE:.0%} of them); a smaller "
                "one may remain")

    def lines(self) -> list[str]:
        """The design in words, as calibrate and plan print it before anything moves."""
        t = self.targets_mm
        lo, hi = self.pitch_band_mm
        out = [f"{len(t)} targets from {t[0]:+g} to {t[-1]:+g} mm at irregular intervals "
               f"(ISO 230-2 4.3.2), each leg read up and down {self.protocol.cycles} times: "
               f"{self.steps} reading steps"
               + (f", {_minutes(self.duration_s)} of machine time at this machine's "
                  f"{self.seconds_per_step:.1f} s a step" if self.seconds_per_step else "")
               + (f" (budget {_minutes(self.budget_s)})" if self.budget_s else ""),
               f"resolves every period from {lo:.3g} to {hi:.3g} mm at {MIN_PHASES} phases or "
               f"more (largest phase gap {self.worst_gap:.2f} of a period; an alias keeps at "
               f"most {self.alias_level:.2f} of a lead's amplitude)" if lo < hi else
               f"resolves no band of periods at {MIN_PHASES} phases: too few targets"]
        if self.stated_mm:
            out.append("the machine file's drive periods and their second harmonics: "
                       + ", ".join(f"{p:g}" for p in self.stated_mm) + " mm")
        if self.alias_level > ALIAS_LIMIT:
            out.append(f"an alias keeps {self.alias_level:.2f} of a lead's amplitude: a pitch "
                       "found may be another's alias (a longer --scan-minutes would tell)")
        if self.unsampled_mm:
            out.append("NOT sampled at 4 phases within the budget: "
                       + ", ".join(f"{p:g} mm" for p in self.unsampled_mm)
                       + " (a longer --scan-minutes would)")
        if not self.band_covered:
            out.append(f"the band asked for, {self.required_mm[0]:g} to "
                       f"{self.required_mm[1]:g} mm, is not covered within the budget "
                       "(a longer --scan-minutes would)")
        out.append(f"detection limit ({DETECTION_SIGMAS:g} sigma at the gauge noise "
                   f"{self.noise_mm * UM_PER_MM:.2g} µm"
                   + (f", most of it the {self.display_step_mm:g} mm display's rounding, "
                      "which a posture's cycles share: they count about once"
                      if self.rounding_repeated else "") + "): "
                   + ", ".join(f"{FAMILY_WORDS[f]} {v * UM_PER_MM:.2g} µm" if math.isfinite(v)
                               else f"{FAMILY_WORDS[f]} not determined (too few targets)"
                               for f, v in self.detection_mm.items()))
        out += self._found_lines()
        if math.isfinite(self.detection_mm.get("screw_map", math.inf)):
            out.append("the smooth map's is for its shape beyond a constant and a slope (the "
                       "joint offset's and the encoder scale's), the least visible one of an "
                       f"{SMOOTH_KNOTS}-knot spline over the travel, as an rms")
        if self.target_steps:
            out.append(f"{DETECTION_TARGET_MM * UM_PER_MM:g} µm in every family would need "
                       f"about {self.target_steps} reading steps"
                       + (f" ({_minutes(self.target_steps * self.seconds_per_step)}: a longer "
                          "--scan-minutes)" if self.seconds_per_step else "")
                       + ("; gauges of a finer display would need far fewer: the display's "
                          "rounding, not their scatter, sets these limits"
                          if self.rounding_repeated else ""))
        if self.smooth_bound_mm:
            out.append(f"no placing of {len(self.targets_mm)} targets along the travel sees "
                       f"the smooth map below {self.smooth_bound_mm * UM_PER_MM:.2g} µm (the "
                       "bound of its information-optimal allocation): a leg's gauges read "
                       "across its axis, so its joint's error along the axis reaches them "
                       "only through the legs' tilt; a positioning test along the axis's "
                       "own line (ISO 230-2) sees it whole")
        return out

    def _found_lines(self) -> list[str]:
        found = self.found_mm.get("lead_screw_cyclic")
        if found is None:
            return []
        if not math.isfinite(found):
            return ["a cyclic error's pitch may stay unresolved at any size: a pitch apart "
                    "from the lead fits alike"]
        return [f"a cyclic error is found reliably ({FOUND_SHARE:.0%} of them) from about "
                f"{found * UM_PER_MM:.2g} µm at its worst lead: the search tries every pitch "
                "of the band, and says a pitch between rival peaks unresolved (the figure "
                "above is for a pitch known)"]

    def to_json(self) -> dict[str, Any]:
        return {"targets_mm": list(self.targets_mm), "cycles": self.protocol.cycles,
                "reading_steps": self.steps, "duration_s": round(self.duration_s, 1),
                "seconds_per_step": round(self.seconds_per_step, 3),
                "budget_s": self.budget_s,
                "required_band_mm": list(self.required_mm),
                "stated_periods_mm": list(self.stated_mm),
                "pitch_band_mm": list(self.pitch_band_mm),
                "unsampled_mm": list(self.unsampled_mm),
                "largest_phase_gap": round(self.worst_gap, 4),
                "alias_level": round(self.alias_level, 4),
                "noise_mm": self.noise_mm,
                "detection_target_steps": self.target_steps or None,
                "smooth_bound_mm": round(self.smooth_bound_mm, 7) or None,
                "detection_mm": {f: round(v, 7) if math.isfinite(v) else None
                                 for f, v in self.detection_mm.items()},
                "found_mm": {f: round(v, 7) if math.isfinite(v) else None
                             for f, v in self.found_mm.items()}}


FAMILY_WORDS = {"lead_screw_cyclic": "cyclic error", "screw_map": "smooth map",
                "hysteresis": "hysteresis"}


def _minutes(seconds: float | None) -> str:
    return f"{(seconds or 0.0) / 60:.0f} min"


def phase_gaps(targets_mm: np.ndarray, frequencies: np.ndarray) -> np.ndarray:
    """(F,) the largest circular gap between the targets' phases at each frequency
    (1/mm), as a share of the period."""
    phases = np.sort(np.outer(frequencies, targets_mm) % 1.0, axis=1)
    inner = np.diff(phases, axis=1).max(axis=1) if targets_mm.size > 1 else \
        np.zeros(len(frequencies))
    return np.maximum(inner, phases[:, 0] + 1.0 - phases[:, -1])


def frequency_grid(targets_mm: np.ndarray, band_mm: tuple[float, float],
                   resolution: float = PHASE_GRID) -> np.ndarray:
    """Frequencies covering the band so finely that no target's phase moves by more
    than ``PHASE_GRID`` of a period between neighbours (phases taken about the
    targets' centre, which a gap does not depend on)."""
    reach = float(np.max(np.abs(targets_mm - targets_mm.mean()))) or 1.0
    df = resolution / reach
    lo, hi = 1.0 / band_mm[1], 1.0 / band_mm[0]
    return np.linspace(lo, hi, max(2, int(math.ceil((hi - lo) / df)) + 1))


def resolved_band(targets_mm: np.ndarray, longest_mm: float,
                  shortest_mm: float) -> tuple[tuple[float, float], float]:
    """The band of periods, from ``longest_mm`` down, every one of which the targets
    sample (gap at most a quarter), and the largest gap within it."""
    centred = targets_mm - targets_mm.mean()
    freqs = frequency_grid(targets_mm, (shortest_mm, longest_mm))
    gaps = phase_gaps(centred, freqs)
    bad = np.nonzero(gaps > LARGEST_PHASE_GAP)[0]
    last = (bad[0] - 1) if len(bad) else len(freqs) - 1
    if last < 0:
        return (longest_mm, longest_mm), float(gaps[0])
    return (1.0 / float(freqs[last]), longest_mm), float(gaps[:last + 1].max())


def stated_periods(machine: MachineSpec, legs: tuple[str, ...]) -> tuple[float, ...]:
    """Every stated drive period of the scanned axes and its harmonics."""
    return tuple(sorted({round(p / h, 6) for a in legs
                         for p in machine.screw(a).periods_mm() for h in HARMONICS}))


def stratified_targets(lo: float, hi: float, n: int, seed: int,
                       strata: Strata | None = None) -> np.ndarray:
    """``n`` targets from ``lo`` to ``hi``: both ends, and one in each of the ``n - 2``
    strata between, jittered within its middle 80 % (so that neighbours stay a fifth of
    a stratum apart), rounded to the micrometre. The strata are equal in length, or in
    the share ``strata`` (cumulative share, position) gives them."""
    inner = n - 2
    u = np.random.default_rng(seed).random(inner)
    if strata is None:
        t = lo + (np.arange(inner) + 0.1 + 0.8 * u) * ((hi - lo) / inner)
    else:
        t = np.interp((np.arange(inner) + 0.1 + 0.8 * u) / inner, *strata)
    return np.round(np.concatenate([[lo], t, [hi]]), 3)


def alias_level(targets_mm: np.ndarray, shortest_mm: float) -> float:
    """The largest sidelobe of the targets' spectral window |sum exp(2 pi i df t)| / n
    beyond its main lobe (df from 2 / span) up to twice the band's highest frequency:
    the share of a period's amplitude that reappears at another period of the band
    (a uniform step d puts a whole alias at 1 / d)."""
    span = float(np.ptp(targets_mm)) or 1.0
    df = np.arange(2.0 / span, 2.0 / shortest_mm, 0.1 / span)
    window = np.abs(np.exp(2j * np.pi * np.outer(df, targets_mm - targets_mm.mean()))
                    .sum(axis=1)) / len(targets_mm)
    return float(window.max()) if len(df) else 1.0


def jitters(lo: float, hi: float, n: int, strata: Strata | None = None,
            ) -> Iterator[np.ndarray]:
    """The ``SEEDS`` jitters of the strata (none with two targets in a micrometre)."""
    for seed in range(SEEDS):
        t = stratified_targets(lo, hi, n, seed, strata)
        if np.all(np.diff(t) > 0.0):
            yield t


def worst_gap(targets_mm: np.ndarray, band: tuple[float, float] | None,
              stated: tuple[float, ...]) -> float:
    """The targets' largest phase gap over the band (None: none; on the coarser search
    grid) and at the stated periods, as a share of the period."""
    freqs = frequency_grid(targets_mm, band, SEARCH_GRID) if band is not None else ()
    return float(phase_gaps(targets_mm - targets_mm.mean(), np.concatenate(
        [freqs, 1.0 / np.asarray(stated, dtype=float)])).max(initial=0.0))


def _score(targets_mm: np.ndarray, band: tuple[float, float],
           stated: tuple[float, ...]) -> float:
    """The targets' worst phase gap and their alias level, the larger of the two as a
    share of its bound: at most 1 meets both."""
    shortest = min((*stated, *band))
    return max(worst_gap(targets_mm, band, stated) / LARGEST_PHASE_GAP,
               alias_level(targets_mm, shortest) / ALIAS_LIMIT)


@lru_cache(maxsize=64)  # a design tries counts upward; designs of one machine share them
def _best_targets(lo: float, hi: float, n: int, band: tuple[float, float],
                  stated: tuple[float, ...]) -> np.ndarray:
    """The jitter of equal strata furthest within the bounds (read-only: shared)."""
    best = min(jitters(lo, hi, n), key=lambda t: _score(t, band, stated))
    best.flags.writeable = False
    return best


def design_scan(machine: MachineSpec, base: ProtocolConfig, *, noise_mm: float,
                seconds_per_step: float = 0.0, budget_s: float | None = None,
                grow: bool = True) -> ScanDesign:
    """The separating scan for ``machine`` of the legs ``base`` reads (``base``: the
    campaign's legs, settling and overshoot): its targets the fewest that sample the
    band within ``budget_s`` of machine time at ``seconds_per_step``, placed where the
    smooth map is seen best within those bounds, more where that reaches
    ``DETECTION_TARGET_MM`` within the budget (``grow``: a budget given for that; not
    grown, the design says what would reach it)."""
    legs = base.legs
    protocol = replace(base, postures=(), approach="both", cycles=DESIGN_CYCLES,
                       scan_step_mm=None, scan_from_mm=None, scan_to_mm=None)
    lo = machine.rho_min_mm + protocol.overshoot_mm
    hi = machine.rho_max_mm - protocol.overshoot_mm
    longest = min(UNSTATED_BAND_MM[1], (hi - lo) / PERIODS_OVER_TRAVEL)
    stated = stated_periods(machine, legs)
    # The band is continuous even where every axis states its lead: the diagnosis
    # searches a band of pitches, and one sampled only at the stated periods handed it
    # the longest few (a stated 5 mm lead on 21 targets: 28-40 mm searched, the lead
    # missed). It starts at the shortest stated period the search takes.
    shortest_asked = max(min(stated), SHORTEST_LEAD_MM) \
        if all(machine.screw(a).lead_mm for a in legs) else UNSTATED_BAND_MM[0]
    required = (min(shortest_asked, longest), longest)
    per_leg = 1 + 2 * DESIGN_CYCLES  # steps per target and leg, and the Zero reading
    timed = bool(budget_s) and seconds_per_step > 0
    most = _most_positions(budget_s if timed else None, seconds_per_step, len(legs),
                           per_leg)
    n = min(FEWEST_POSITIONS, most)
    shortest = min(stated + required)
    scan = _Scan(machine, replace(protocol, scan_targets_mm=(lo, hi)), noise_mm, required,
                 stated, longest, shortest)
    n, placed, wanted = _counted_and_placed(scan, n, most, timed, grow)
    targets = placed.targets
    protocol = replace(protocol, scan_targets_mm=tuple(float(t) for t in targets))
    band, band_gap = resolved_band(targets, longest, shortest)
    stated_gaps = phase_gaps(targets - targets.mean(), 1.0 / np.asarray(stated, dtype=float))
    unsampled = tuple(p for p, g in zip(stated, stated_gaps, strict=True)
                      if g > LARGEST_PHASE_GAP)
    gaps = [band_gap, *[g for g in stated_gaps if g <= LARGEST_PHASE_GAP]]
    steps = len(reading_steps(protocol, machine))
    finite = all(math.isfinite(v) for v in placed.detection.values())
    needed = len(legs) * (1 + (per_leg - 1) * wanted) if finite and wanted > n else 0
    smooth = placed.detection.get("screw_map", 0.0)
    # said where no placing of these targets would reach the target either
    bound = smooth_allocation(scan.ends, machine, noise_mm).bound_mm(n, noise_mm) \
        if timed and finite and smooth > DETECTION_TARGET_MM else 0.0
    bound = bound if bound > DETECTION_TARGET_MM else 0.0
    step = machine.gauge_resolution_mm
    found = {"lead_screw_cyclic": cyclic_found_mm(protocol, machine, noise_mm, band, stated)} \
        if band[0] < band[1] else {}
    return ScanDesign(protocol, steps, seconds_per_step, budget_s, required, stated, band,
                      unsampled, max(gaps), noise_mm, placed.detection,
                      alias_level(targets, shortest), needed, bound, step,
                      reading_noise(noise_mm, step).rounding_dominated, found)


def _counted_and_placed(scan: _Scan, n: int, most: int, timed: bool, grow: bool = True,
                        ) -> tuple[int, _Placed, int]:
    """The fewest equal strata that sample the band (from ``n``, at most ``most``),
    placed, and grown while that reaches the detection target within the budget; with
    the count the detection target wants."""
    lo, hi = scan.ends.scan_targets_mm
    while True:
        covered = scan.covers(_best_targets(lo, hi, n, scan.required, scan.stated))
        if covered or n >= most:
            break
        n = min(most, max(n + 1, int(n * 1.12)))
    while True:
        placed = scan.placed(n, covered and timed)
        wanted = targets_for_detection(placed.detection, n)
        if wanted <= n or wanted > most or not (timed and grow):
            # reached, or beyond the budget's reach (or no budget in machine time to
            # grow within): the fewest that sample the band
            return n, placed, wanted
        n = wanted


@dataclass(frozen=True)
class _Placed:
    targets: np.ndarray
    detection: dict[str, float]


@dataclass
class _Scan:
    """The targets of ``n`` strata placed for a machine: equal strata, or strata cut
    partly by where the smooth map is seen (:class:`SmoothAllocation`): of their
    jitters, the one the allocation finds sees the map best among those that keep
    every period sampled, where its limits beat the equal strata's."""

    machine: MachineSpec
    ends: ProtocolConfig  # the scan's protocol, its targets its two ends
    noise_mm: float
    required: tuple[float, float]
    stated: tuple[float, ...]
    longest: float
    shortest: float

    def covers(self, targets: np.ndarray) -> bool:
        """Every stated period and the band required sampled (on the fine grid), no
        alias beyond its bound."""
        band, _ = resolved_band(targets, self.longest, self.shortest)
        return worst_gap(targets, None, self.stated) <= LARGEST_PHASE_GAP and \
            band[0] <= self.required[0] + 1e-9 and \
            alias_level(targets, self.shortest) <= ALIAS_LIMIT

    def placed(self, n: int, informed: bool) -> _Placed:
        """The targets of ``n`` strata: placed for the smooth map where ``informed``
        (within a budget, every period sampled), else equal."""
        lo, hi = self.ends.scan_targets_mm
        equal = _best_targets(lo, hi, n, self.required, self.stated)
        detection = self._detection(equal)
        worst = max(detection.values())
        if informed and DETECTION_TARGET_MM < worst < math.inf:
            return self._informed(n, equal, detection)
        return _Placed(equal, detection)  # no need, no period to spare, or too few targets

    def _informed(self, n: int, equal: np.ndarray, detection: dict[str, float]) -> _Placed:
        lo, hi = self.ends.scan_targets_mm
        allocation = smooth_allocation(self.ends, self.machine, self.noise_mm)
        floor = allocation.limit_mm(equal, self.noise_mm)
        tried = sorted(((allocation.limit_mm(t, self.noise_mm), k, t)
                        for share in INFORMED_SHARES
                        for k, t in enumerate(jitters(lo, hi, n, allocation.strata_edges(
                            share, lo, hi)))), key=lambda c: c[:2])
        for limit, _, targets in tried:  # the smooth map's best first, if it keeps
            if limit >= floor:  # every period sampled as the equal strata do
                break
            if _score(targets, self.required, self.stated) <= 1.0 and self.covers(targets):
                placed = _Placed(targets, self._detection(targets))
                if max(placed.detection.values()) < max(detection.values()):
                    return placed
                break
        return _Placed(equal, detection)

    def _detection(self, targets: np.ndarray) -> dict[str, float]:
        protocol = replace(self.ends, scan_targets_mm=tuple(float(t) for t in targets))
        band, _ = resolved_band(targets, self.longest, self.shortest)
        return detection_limits(protocol, self.machine, self.noise_mm, band, self.stated)


def _most_positions(budget_s: float | None, seconds_per_step: float, legs: int,
                    per_leg: int) -> int:
    """The most targets a leg's scan may have: those the budget of machine time holds
    (each target ``per_leg`` steps, each leg one more), none beyond ``MOST_POSITIONS``."""
    if budget_s is None:
        return MOST_POSITIONS
    return max(3, min(MOST_POSITIONS,
                      int((budget_s / seconds_per_step / legs - 1) // (per_leg - 1))))


def targets_for_detection(detection_mm: dict[str, float], n: int) -> int:
    """The targets that bring every family's limit to ``DETECTION_TARGET_MM``, from
    ``n`` targets' limits: a limit falls as the square root of the readings, which grow
    with the targets, give or take the jitter's (``TARGETS_MARGIN``; a very large count
    where a limit is not determined)."""
    worst = max(detection_mm.values(), default=0.0)
    if not math.isfinite(worst):
        return MOST_POSITIONS + 1
    if worst <= DETECTION_TARGET_MM:
        return n
    return math.ceil(n * (worst / DETECTION_TARGET_MM) ** 2 * TARGETS_MARGIN)


def detection_limits(protocol: ProtocolConfig, machine: MachineSpec, noise_mm: float,
                     band_mm: tuple[float, float],
                     stated_mm: tuple[float, ...] = ()) -> dict[str, float]:
    """Per family, ``DETECTION_SIGMAS`` times the std of its amplitude on the worst
    scanned axis: a cyclic error's (over periods across the band and the stated ones),
    the rms over the travel of a smooth map's least visible shape less its line, a
    hysteresis' lost motion; the readings weighed as the diagnosis weighs them, the
    display's rounding shared by each posture's repeats (:func:`reading_noise`)."""
    rows, history, nuisance = _Rows.planned(protocol, machine, noise_mm)
    lo, hi = protocol.scan_targets_mm[0], protocol.scan_targets_mm[-1]
    periods = sorted({*np.geomspace(band_mm[0], band_mm[1], 12).tolist(), *stated_mm})
    out: dict[str, float] = {}
    for leg in protocol.legs:
        a = AXES.index(leg)
        terms = {"lead_screw_cyclic": [MapTerm("lead_screw_cyclic", a, {"pitch_mm": p})
                                       for p in periods],
                 "screw_map": [_smooth_term(a, lo, hi)],
                 "hysteresis": [MapTerm("hysteresis", a, {"length_mm": BUILD_UP_MM})]}
        for family, family_terms in terms.items():
            # a smooth map's line is the offset's and the scale's
            taken = _orthonormal(rows.nuisance(a)) if family_terms[0].kind.pointwise \
                else nuisance
            worst = max(_amplitude_std(rows.of_term(t, history), taken, t, lo, hi)
                        for t in family_terms)
            out[family] = max(out.get(family, 0.0), DETECTION_SIGMAS * noise_mm * worst)
    return out


def cyclic_found_mm(protocol: ProtocolConfig, machine: MachineSpec, noise_mm: float,
                    band_mm: tuple[float, float], stated_mm: tuple[float, ...] = ()) -> float:
    """The amplitude of a cyclic error the map search takes at ``FOUND_SHARE``, at the
    worst lead of the band and the stated ones, on the worst axis
    (``identify.search_rules``): its test over every pitch of the periodogram and the
    candidates beside it, and its rule against a rival peak, whose share of the error
    is the largest any pitch apart from the lead's main lobe captures (the readings
    weighed as the diagnosis weighs them, the offsets and gauges' zeros taken out)."""
    rows, history, nuisance = _Rows.planned(protocol, machine, noise_mm)
    span = protocol.scan_targets_mm[-1] - protocol.scan_targets_mm[0]
    df = 1.0 / (OVERSAMPLE * span)
    freqs = np.arange(1.0 / band_mm[1], 1.0 / band_mm[0] + df / 2, df)
    candidates = len(protocol.legs) * sum(1 for f in FAMILIES.values() if not f.in_time)
    threshold = max(chi2_threshold(2, LEVEL / (len(freqs) * candidates)),
                    3 * math.log(len(rows.layout)))  # the BIC's price of a sine, a cosine, a pitch
    tested = found_noncentrality(2, threshold)
    periods = sorted({*np.geomspace(band_mm[0], band_mm[1], 12).tolist(), *stated_mm})
    worst = 0.0
    for leg in protocol.legs:
        axis = AXES.index(leg)

        def columns(pitch: float, axis: int = axis) -> np.ndarray:
            cols = rows.of_term(MapTerm("lead_screw_cyclic", axis, {"pitch_mm": pitch}),
                                history)
            return cols - nuisance @ (nuisance.T @ cols)

        bases = np.stack([np.linalg.qr(columns(1.0 / f))[0] for f in freqs])  # (F, n, 2)
        for period in periods:
            cols = columns(period)
            normal = cols.T @ cols
            try:
                std = math.sqrt(float(np.max(np.diag(np.linalg.inv(normal)))))
                unit = cols @ np.linalg.inv(np.linalg.cholesky(normal)).T  # unit-norm signal
            except np.linalg.LinAlgError:
                return math.inf
            captured = np.einsum("fni,nj->fij", bases, unit)
            # the share a pitch captures at a phase drawn at random: half the trace
            shares = np.einsum("fij,fij->f", captured, captured) / 2.0
            sidelobe = _rival_share(shares, freqs, 1.0 / period, OVERSAMPLE * df)
            worst = max(worst, std * math.sqrt(max(tested, resolved_noncentrality(sidelobe))))
    return noise_mm * worst


def _rival_share(shares: np.ndarray, freqs: np.ndarray, lead: float, lobe: float) -> float:
    """The largest share a rival peak captures: a local maximum of ``shares`` over
    ``freqs`` at least ``lobe`` from the lead's frequency, outside the lead's own peak
    (the slope from it down to its first minimum on either side), as the search's
    rule takes its rivals (``diagnose.mapsearch._rival_pitch``)."""
    if len(shares) < 3:  # a band narrower than the lead's own lobe holds no rival
        return 0.0
    peaks = local_maxima(shares)
    own = int(np.argmin(np.abs(freqs - lead)))
    while 0 < own < len(shares) - 1 and shares[own + 1] > shares[own]:
        own += 1
    while 0 < own < len(shares) - 1 and shares[own - 1] > shares[own]:
        own -= 1
    apart = peaks[(peaks != own) & (np.abs(freqs[peaks] - lead) >= lobe)]
    return float(np.max(shares[apart], initial=0.0))


def reading_noise(noise_mm: float, step_mm: float) -> GaugeNoise:
    """A reading's noise as the design counts it: ``noise_mm`` in all, of which the part
    of the display's rounding that the gauge's scatter does not dither away repeats
    with the cycles of a posture (``identify.noise``: ``c(sigma, s)``, the diagnosis's
    own covariance), the scatter being what the rounding's ``s^2 / 12`` leaves of it.
    On a 10 um display with a gauge repeating to 0.5 um the cycles' repeats round alike
    and carry one reading's worth; on a 1 um one they are independent."""
    scatter = math.sqrt(max(noise_mm**2 - step_mm**2 / 12.0, 0.0))
    shared = min(shared_rounding_variance(scatter, step_mm), noise_mm**2)
    return GaugeNoise(noise_mm, "design", step_mm, scatter, shared)


@dataclass(frozen=True)
class _Rows:
    """A layout's readings as the detection limits weigh them: each joint's columns
    (per unit of its displacement at the reading and at the gauge's setting), and the
    whitening that makes a unit of every whitened reading one noise."""

    s_r: np.ndarray  # (n, 3) along each joint's line, at the reading
    s_s: np.ndarray  # (n, 3) at the gauge's setting pose
    layout: ReadingsLayout
    whiten: Callable[[np.ndarray], np.ndarray]  # along the last axis: (..., n)

    @classmethod
    def planned(cls, protocol: ProtocolConfig, machine: MachineSpec,
                noise_mm: float) -> tuple[_Rows, JointHistory, np.ndarray]:
        """The rows of ``protocol``'s planned readings, their joints' history and the
        orthonormal directions of the offsets and the gauges' zeros."""
        rows = cls.of(planned_layout(protocol, machine), machine, noise_mm)
        return rows, JointHistory.of(rows.layout), _orthonormal(rows.offsets)

    @classmethod
    def of(cls, layout: ReadingsLayout, machine: MachineSpec, noise_mm: float) -> _Rows:
        s_r, s_s = joint_sensitivity(vector(), layout, machine).along()
        noise = reading_noise(noise_mm, machine.gauge_resolution_mm)
        whiten = GroupWhitener(Observations(machine, layout, np.zeros(len(layout)), []), noise)
        return cls(s_r, s_s, layout, whiten)

    @property
    def offsets(self) -> np.ndarray:
        """(n, 3 + G) each joint offset's column (the same shift everywhere), and each
        gauge's zero (every reading of that gauge: a gauge reads from where it was set,
        a constant the fit takes for each gauge as the diagnosis does)."""
        lay = self.layout
        zeros = np.eye(lay.n_gauges)[lay.gauge]
        return self.whiten(np.column_stack([self.s_r + self.s_s, zeros]).T).T

    def nuisance(self, axis: int) -> np.ndarray:
        """(n, 4 + G) the offsets, the gauges' zeros and the axis's encoder scale: a
        shift in proportion to q (parameters.py's encoder_scale, its column in the
        model's Jacobian up to the ppm unit), a smooth map's slope."""
        lay = self.layout
        scale = self.s_r[:, axis] * lay.q_mm[:, axis] + \
            self.s_s[:, axis] * lay.setting_q_mm[lay.gauge, axis]
        return np.column_stack([self.offsets, self.whiten(scale)])

    def of_term(self, term: MapTerm, history: JointHistory) -> np.ndarray:
        """(n, k) the term's columns: its displacement through the joint's sensitivity."""
        at_reading, at_setting = term.columns(history)
        a = term.axis
        cols = at_reading * self.s_r[None, :, a] + \
            at_setting[:, self.layout.gauge] * self.s_s[None, :, a]
        return self.whiten(cols).T


def _smooth_term(axis: int, lo: float, hi: float) -> MapTerm:
    return MapTerm("screw_map", axis, {"from_mm": lo, "to_mm": hi, "knots": SMOOTH_KNOTS})


def _orthonormal(columns: np.ndarray) -> np.ndarray:
    u, s, _ = np.linalg.svd(columns, full_matrices=False)
    return u[:, s > s[0] * 1e-10]


def _amplitude_std(cols: np.ndarray, nuisance: np.ndarray, term: MapTerm, lo: float,
                   hi: float) -> float:
    """The std of the term's amplitude per unit reading noise from its whitened
    columns (n, k), the nuisance directions taken out: a cyclic error's amplitude
    (either quadrature: the larger), the rms over ``lo..hi`` of a smooth map's least
    visible shape less its line, a lost motion's value."""
    cols = cols - nuisance @ (nuisance.T @ cols)
    normal = cols.T @ cols
    if term.kind.pointwise:  # a smooth map: its values along q
        return _least_visible_rms(normal, _unit_shapes(term, lo, hi))
    try:
        cov = np.linalg.inv(normal)
    except np.linalg.LinAlgError:
        return math.inf
    return float(np.sqrt(max(float(np.max(np.diag(cov))), 0.0)))


def _unit_shapes(term: MapTerm, lo: float, hi: float) -> np.ndarray:
    """(k, p) the map's coefficients of shapes whose rest beyond their line over
    ``lo..hi`` is of unit rms and orthogonal: the eigenvectors of the Gram matrix of its
    shapes less their line, scaled. The line's directions are the nuisance's (the
    offset's constant, the scale's slope), which the normal matrix is blind to as
    well, so they are left out."""
    grid = np.linspace(lo, hi, 101)
    basis = term.shape_of(grid, np.ones_like(grid), np.full_like(grid, np.inf),
                          np.zeros_like(grid))  # (k, 101)
    line = np.column_stack([np.ones_like(grid), grid])
    rest = basis - (line @ np.linalg.lstsq(line, basis.T, rcond=None)[0]).T
    gram = rest @ rest.T / len(grid)
    size, directions = np.linalg.eigh(gram)
    kept = size > size.max() * 1e-9
    return directions[:, kept] / np.sqrt(size[kept])


def _least_visible_rms(normal: np.ndarray, unit_shapes: np.ndarray) -> float:
    """1 / sqrt of the smallest eigenvalue of ``normal`` (the map's coefficients, the
    offsets and scales taken out) on the unit-rms shapes: the rms of the smooth map,
    its line apart, that the readings see least, per unit of their noise."""
    seen = np.linalg.eigvalsh(unit_shapes.T @ normal @ unit_shapes)
    if seen[0] <= seen[-1] * 1e-10 or seen[0] <= 0.0:
        return math.inf  # a shape the readings do not see at all: too few targets
    return float(1.0 / math.sqrt(seen[0]))


@dataclass(frozen=True)
class SmoothAllocation:
    """Where along the travel the smooth map's least visible shape is seen: the
    allocation of the targets over candidates every ``CANDIDATE_STEP_MM`` that
    maximises the smallest eigenvalue of its normal matrix (E-optimal: the criterion
    of the limit itself; Pukelsheim, "Optimal Design of Experiments", 1993, ch. 6),
    every leg read at each target as the design reads it, the joint offsets and the
    encoder scale taken out, on the worst axis. Found by multiplicative steps on the
    soft minimum of the eigenvalues (Silvey, Titterington and Torsney's algorithm,
    Commun. Stat. A7, 1978, on that criterion), and bounded from its dual: for any
    mixture of unit shapes ``u_k`` (weights ``alpha_k``) the smallest eigenvalue of
    any design of ``n`` targets is at most ``sum alpha_k u_k' (Z + n M_s) u_k`` at the
    best single candidate ``s``, which no allocation, on the grid or between, beats."""

    candidates_mm: np.ndarray  # (S,)
    weights: np.ndarray  # (S,) summing to one
    best_seen: float  # the dual's largest information of one target, per unit noise^2
    setting_seen: float  # what the gauges' setting readings add to it
    per_target: np.ndarray  # (A, S, d, d) each axis's information of a target there
    setting: np.ndarray  # (A, d, d) of the gauges' setting readings
    shapes: int  # the first coordinates of d: the map's unit shapes

    def limit_mm(self, targets_mm: np.ndarray, noise_mm: float) -> float:
        """The smooth map's limit at these targets, their information taken linearly
        between the candidates' (a proxy of :func:`detection_limits` that costs no
        layout: what the strata are chosen by)."""
        at = np.interp(targets_mm, self.candidates_mm, np.arange(len(self.candidates_mm)))
        below = np.floor(at).astype(int)
        above = np.minimum(below + 1, len(self.candidates_mm) - 1)
        weights = np.bincount(below, 1.0 - (at - below), len(self.candidates_mm)) + \
            np.bincount(above, at - below, len(self.candidates_mm))
        return self._limit(weights, noise_mm)

    def allocated_mm(self, targets: int, noise_mm: float) -> float:
        """The limit of the allocation itself, ``targets`` targets' worth of weight: what
        the relaxation reaches (whole targets cannot place fractions)."""
        return self._limit(targets * self.weights, noise_mm)

    def _limit(self, weights: np.ndarray, noise_mm: float) -> float:
        least = min(float(_schur(m, self.shapes)[0][0]) for m in
                    self.setting + np.einsum("s,asij->aij", weights, self.per_target))
        return DETECTION_SIGMAS * noise_mm / math.sqrt(least) if least > 0 else math.inf

    def bound_mm(self, targets: int, noise_mm: float) -> float:
        """The least smooth-map limit any allocation of ``targets`` targets reaches."""
        seen = self.setting_seen + targets * self.best_seen
        return DETECTION_SIGMAS * noise_mm / math.sqrt(seen) if seen > 0 else math.inf

    def strata_edges(self, share: float, lo: float, hi: float) -> tuple[np.ndarray, np.ndarray]:
        """(cumulative share, position): ``share`` of the strata cut equal in the
        allocation's weight (each candidate's spread over ``SPREAD_MM``, a target's
        jitter), the rest equal in length."""
        x = np.linspace(lo, hi, 2001)
        kernel = np.exp(-0.5 * ((x[None] - self.candidates_mm[:, None]) / SPREAD_MM) ** 2)
        kernel /= kernel.sum(axis=1, keepdims=True)
        density = (1.0 - share) / len(x) + share * (self.weights @ kernel)
        cumulative = np.concatenate([[0.0], np.cumsum(density[1:] + density[:-1])])
        return cumulative / cumulative[-1], x


@lru_cache(maxsize=4)  # one machine and its legs' travel, every count of targets tried
def smooth_allocation(protocol: ProtocolConfig, machine: MachineSpec,
                      noise_mm: float) -> SmoothAllocation:
    """The allocation for the scan ``protocol`` reads (its legs, cycles and ends),
    its targets replaced by every candidate."""
    lo, hi = protocol.scan_targets_mm[0], protocol.scan_targets_mm[-1]
    count = max(2, int(round((hi - lo) / CANDIDATE_STEP_MM)) + 1)
    candidates = np.round(np.linspace(lo, hi, count), 3)
    grid = replace(protocol, scan_targets_mm=tuple(float(c) for c in candidates))
    layout = planned_layout(grid, machine)
    setting = layout.posture == "zero"
    at = np.searchsorted(candidates, layout.q_mm[np.arange(len(layout)), layout.leg])
    at = np.where(setting, -1, np.clip(at, 0, count - 1))
    return allocation_of(layout, machine, noise_mm, at, candidates,
                         tuple(AXES.index(leg) for leg in protocol.legs), (lo, hi))


def allocation_of(layout: ReadingsLayout, machine: MachineSpec, noise_mm: float,
                  at: np.ndarray, candidates_mm: np.ndarray, axes: tuple[int, ...],
                  travel_mm: tuple[float, float]) -> SmoothAllocation:
    """The allocation over the candidate postures of ``layout``: ``at`` (n,) each
    reading's candidate (-1: the gauges' setting readings, which every design has),
    ``candidates_mm`` what each is called by, the smooth maps of ``axes`` over
    ``travel_mm``."""
    rows = _Rows.of(layout, machine, noise_mm)
    history = JointHistory.of(layout)
    setting = at < 0
    blocks, settings, sizes = [], [], []
    for a in axes:
        term = _smooth_term(a, *travel_mm)
        shapes = rows.of_term(term, history) @ _unit_shapes(term, *travel_mm)
        x = np.column_stack([shapes, rows.nuisance(a)])
        outer = x[:, :, None] * x[:, None, :]
        per = np.zeros((len(candidates_mm), x.shape[1], x.shape[1]))
        np.add.at(per, at[~setting], outer[~setting])
        blocks.append(per)
        settings.append(outer[setting].sum(axis=0))
        sizes.append(shapes.shape[1])
    per_target, setting_info = np.array(blocks), np.array(settings)
    weights, best, zero = _allocate(per_target, setting_info, sizes[0])
    return SmoothAllocation(candidates_mm, weights, best, zero, per_target, setting_info,
                            sizes[0])


def _allocate(per_target: np.ndarray, setting: np.ndarray,
              shapes: int) -> tuple[np.ndarray, float, float]:
    """(weights, the dual's best single target's information, the settings' part of
    the dual) for ``per_target`` (A, S, d, d): each axis's information of one target,
    its first ``shapes`` coordinates the map's unit shapes, the rest the nuisance;
    ``setting`` (A, d, d) what the gauges' setting readings add. Mirror ascent (the
    exponentiated gradient, its step falling as one over the root of the rounds) on the
    soft minimum of every axis's eigenvalues."""
    count = per_target.shape[1]
    weights = np.full(count, 1.0 / count)
    best, held, found = math.inf, 0.0, (0.0, weights)
    for round_ in range(ALLOCATION_ROUNDS):
        least, gain, zero = _soft_least(weights, per_target, setting, shapes)
        if gain.max() < best:  # the tightest bound met on the way
            best, held = float(gain.max()), zero
        if least > found[0]:  # and the best allocation
            found = (least, weights)
        if best < found[0] * (1.0 + ALLOCATION_GAP):
            break
        weights = weights * np.exp(gain / gain.max() / math.sqrt(round_ + 1))
        weights /= weights.sum()
    return found[1], best, held


def _schur(normal: np.ndarray, shapes: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The eigenvalues and eigenvectors of the information on the first ``shapes``
    coordinates once the rest (the nuisance) is fitted alongside, and the nuisance's
    regression on them."""
    taken = np.linalg.solve(normal[shapes:, shapes:], normal[shapes:, :shapes])
    values, vectors = np.linalg.eigh(normal[:shapes, :shapes] - normal[:shapes, shapes:] @ taken)
    return values, vectors, taken


def _soft_least(weights: np.ndarray, per_target: np.ndarray, setting: np.ndarray,
                shapes: int) -> tuple[float, np.ndarray, float]:
    """The least eigenvalue of the allocation's information (per unit weight) over the
    axes, each target's gain in the soft minimum's direction (its gradient, and the dual
    bound's terms: ``sum alpha_k u_k' M_s u_k``), and the settings' term of that sum."""
    normal = np.einsum("s,asij->aij", weights, per_target)
    seen, vectors = [], []
    for m in normal:
        values, v, taken = _schur(m, shapes)
        seen.append(values)
        vectors.append(np.vstack([v, -taken @ v]))  # each shape with its best nuisance
    least = float(np.min(seen))
    gain, zero, total = np.zeros(per_target.shape[1]), 0.0, 0.0
    for values, u, m_s, z in zip(seen, vectors, per_target, setting, strict=True):
        alpha = np.exp(-SOFT_MIN * (values / least - 1.0))
        mixed = (u * alpha) @ u.T  # sum_k alpha_k u_k u_k'
        gain += np.tensordot(m_s, mixed, axes=([1, 2], [0, 1]))
        zero += float(np.sum(z * mixed))
        total += float(alpha.sum())
    return least, gain / total, zero / total


def sampled_band(protocol: ProtocolConfig, machine: MachineSpec,
                 ) -> tuple[float, float] | None:
    """The band of periods a designed scan's targets sample, as its design found it
    (None: not a designed scan): what the diagnosis of its readings searches."""
    targets = np.asarray(protocol.scan_targets_mm, dtype=float)
    if targets.size < 3:
        return None
    longest = min(UNSTATED_BAND_MM[1], float(np.ptp(targets)) / PERIODS_OVER_TRAVEL)
    stated = stated_periods(machine, protocol.legs)
    band, _ = resolved_band(targets, longest, min((*stated, UNSTATED_BAND_MM[0], longest)))
    return band


BETWEEN_SEED = 1  # the validation's jitter: fixed, so a resumed procedure reads the same


def between_plan(protocol: ProtocolConfig, machine: MachineSpec) -> ProtocolConfig:
    """The scan that validates a scan's maps at other targets: one between each two of
    its targets, jittered within the middle 40 % of the gap (irregular, none where the
    identification read). A map aliased on the first targets, or an error they sampled
    at one phase, differs there from what it predicts."""
    targets = np.asarray(scan_targets(protocol, machine), dtype=float)
    u = np.random.default_rng(BETWEEN_SEED).random(len(targets) - 1)
    between = np.round(targets[:-1] + (0.3 + 0.4 * u) * np.diff(targets), 3)
    return protocol.at_targets(tuple(float(t) for t in between))
