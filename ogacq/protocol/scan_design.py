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
  machine file) and its second harmonic, and, where an axis states none, every lead
  from 2 to 40 mm (``UNSTATED_BAND_MM``: miniature to high-helix ball screws of a
  machine this size);
* the targets are read up and back down from beyond each end (ISO 230-2 4.3's
  bidirectional cycle: both sides where a lost motion or hysteresis may be, the
  whole travel between reversals for a wind-up), two cycles (the repeats measure the
  gauge noise the verdict needs);
* ``n`` is the fewest that sample the band, within the time budget; a budget too
  small for it gives the most the budget allows, and what that leaves unsampled is
  said.

The detection limit of each family is ``DETECTION_SIGMAS`` times the std of its
amplitude at the gauge noise, from the design's normal matrix: each family's columns
(``ogacq.model.error_maps``) through the joint sensitivities of the planned readings,
less what the joint offsets take (``C' (I - P_B) C``). A smooth map's constant is
its joint offset's and its slope its axis's encoder scale's, exactly: its
limit is stated for the rest, the map less its straight line over the travel, as the
rms of the least visible such shape (the smallest generalised eigenvalue of the normal
matrix against the maps' rms over the travel), one shape as the other families' one
amplitude. It is set by the sensitivity, not by where the targets are: a leg's gauges
read across its own axis, so its joint's error reaches them only through the other
legs' tilt (at most 0.13 of it on the built-in machine, none near the Zero posture),
and the other legs' scans move it over a sixth of its travel. Targets twice as dense
near the ends or mid-travel, tried, raised the figure (2.2 against 2.0 um); it falls
as the square root of the reading steps (bench/bench_smooth_map.py prints it against
the budget).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from ogacq.model.error_maps import JointHistory, MapTerm
from ogacq.model.joint_sensitivity import joint_sensitivity
from ogacq.model.machine import MachineSpec
from ogacq.model.parameters import AXES, vector
from ogacq.model.units import UM_PER_MM
from ogacq.protocol.plan import ProtocolConfig, planned_layout, reading_steps, scan_targets

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


@dataclass(frozen=True)
class ScanDesign:
    """A designed separating scan and what it resolves."""

    protocol: ProtocolConfig
    steps: int  # reading steps, every leg
    seconds_per_step: float  # this machine's, measured (0: not known)
    budget_s: float | None  # the time allowed (None: none)
    required_mm: tuple[float, float] | None  # the unstated band asked for (None: all stated)
    stated_mm: tuple[float, ...]  # stated periods and their harmonics, to sample
    pitch_band_mm: tuple[float, float]  # every period in it sampled at >= MIN_PHASES
    unsampled_mm: tuple[float, ...]  # stated periods the design misses (budget short)
    worst_gap: float  # the largest phase gap over the band and the stated, of a period
    noise_mm: float
    detection_mm: dict[str, float]  # family -> DETECTION_SIGMAS x its amplitude's std
    alias_level: float = 0.0  # the spectral window's largest sidelobe (alias_level)
    target_steps: int = 0  # the reading steps DETECTION_TARGET_MM would need (0: reached)

    @property
    def targets_mm(self) -> tuple[float, ...]:
        return self.protocol.scan_targets_mm

    @property
    def duration_s(self) -> float:
        return self.steps * self.seconds_per_step

    @property
    def complete(self) -> bool:
        """Samples all it was asked to (the unstated band and every stated period)."""
        return not self.unsampled_mm and (self.required_mm is None or (
            self.pitch_band_mm[0] <= self.required_mm[0] + 1e-9
            and self.pitch_band_mm[1] >= self.required_mm[1] - 1e-9))

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
        if self.required_mm and not self.complete:
            out.append(f"the band asked for, {self.required_mm[0]:g} to "
                       f"{self.required_mm[1]:g} mm, is not covered within the budget "
                       "(a longer --scan-minutes would)")
        out.append(f"detection limit ({DETECTION_SIGMAS:g} sigma at the gauge noise "
                   f"{self.noise_mm * UM_PER_MM:.2g} µm): "
                   + ", ".join(f"{FAMILY_WORDS[f]} {v * UM_PER_MM:.2g} µm" if math.isfinite(v)
                               else f"{FAMILY_WORDS[f]} not determined (too few targets)"
                               for f, v in self.detection_mm.items()))
        if math.isfinite(self.detection_mm.get("screw_map", math.inf)):
            out.append("the smooth map's is for its shape beyond a constant and a slope (the "
                       "joint offset's and the encoder scale's), the least visible one of an "
                       f"{SMOOTH_KNOTS}-knot spline over the travel, as an rms")
        if self.target_steps:
            out.append(f"{DETECTION_TARGET_MM * UM_PER_MM:g} µm in every family would need "
                       f"about {self.target_steps} reading steps"
                       + (f" ({_minutes(self.target_steps * self.seconds_per_step)}: a longer "
                          "--scan-minutes)" if self.seconds_per_step else ""))
        return out

    def to_json(self) -> dict[str, Any]:
        return {"targets_mm": list(self.targets_mm), "cycles": self.protocol.cycles,
                "reading_steps": self.steps, "duration_s": round(self.duration_s, 1),
                "seconds_per_step": round(self.seconds_per_step, 3),
                "budget_s": self.budget_s,
                "required_band_mm": list(self.required_mm) if self.required_mm else None,
                "stated_periods_mm": list(self.stated_mm),
                "pitch_band_mm": list(self.pitch_band_mm),
                "unsampled_mm": list(self.unsampled_mm),
                "largest_phase_gap": round(self.worst_gap, 4),
                "alias_level": round(self.alias_level, 4),
                "noise_mm": self.noise_mm,
                "detection_target_steps": self.target_steps or None,
                "detection_mm": {f: round(v, 7) if math.isfinite(v) else None
                                 for f, v in self.detection_mm.items()}}


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


def stratified_targets(lo: float, hi: float, n: int, seed: int) -> np.ndarray:
    """``n`` targets from ``lo`` to ``hi``: both ends, and one in each of the ``n - 2``
    equal strata between, jittered within its middle 80 % (so that neighbours stay a
    fifth of a stratum apart), rounded to the micrometre."""
    inner = n - 2
    width = (hi - lo) / inner
    u = np.random.default_rng(seed).random(inner)
    t = lo + (np.arange(inner) + 0.1 + 0.8 * u) * width
    return np.round(np.concatenate([[lo], t, [hi]]), 3)


def _gap_at(targets_mm: np.ndarray, periods: tuple[float, ...]) -> np.ndarray:
    if not periods:
        return np.zeros(0)
    return phase_gaps(targets_mm - targets_mm.mean(), 1.0 / np.asarray(periods))


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


def _best_targets(lo: float, hi: float, n: int, band: tuple[float, float] | None,
                  stated: tuple[float, ...]) -> tuple[np.ndarray, float]:
    """The jitter, of ``SEEDS`` tried, whose worst gap over the band and the stated
    periods, and whose alias level, are furthest within their bounds (the larger of
    the two as a share of its bound: at most 1 meets both)."""
    best: tuple[float, np.ndarray] | None = None
    freqs = None
    shortest = min((*stated, *(band or ())), default=UNSTATED_BAND_MM[0])
    for seed in range(SEEDS):
        t = stratified_targets(lo, hi, n, seed)
        centred = t - t.mean()
        if band is not None and freqs is None:
            freqs = frequency_grid(t, band, SEARCH_GRID)
        worst = max([float(phase_gaps(centred, freqs).max())] if freqs is not None else [0.0])
        worst = max([worst, *_gap_at(t, stated).tolist()])
        score = max(worst / LARGEST_PHASE_GAP, alias_level(t, shortest) / ALIAS_LIMIT)
        if best is None or score < best[0]:
            best = (score, t)
    assert best is not None
    return best[1], best[0]


def design_scan(machine: MachineSpec, base: ProtocolConfig, *, noise_mm: float,
                seconds_per_step: float = 0.0, budget_s: float | None = None,
                ) -> ScanDesign:
    """The separating scan for ``machine`` of the legs ``base`` reads (``base``: the
    campaign's legs, settling and overshoot), its targets the fewest that sample the
    band within ``budget_s`` of machine time at ``seconds_per_step``."""
    legs = base.legs
    protocol = replace(base, postures=(), approach="both", cycles=DESIGN_CYCLES,
                       scan_step_mm=None, scan_from_mm=None, scan_to_mm=None)
    lo = machine.rho_min_mm + protocol.overshoot_mm
    hi = machine.rho_max_mm - protocol.overshoot_mm
    longest = min(UNSTATED_BAND_MM[1], (hi - lo) / PERIODS_OVER_TRAVEL)
    required = None if all(machine.screw(a).lead_mm for a in legs) else \
        (min(UNSTATED_BAND_MM[0], longest), longest)
    stated = stated_periods(machine, legs)
    per_leg = 1 + 2 * DESIGN_CYCLES  # steps per target and leg, and the Zero reading
    timed = bool(budget_s) and seconds_per_step > 0
    most = _most_positions(budget_s if timed else None, seconds_per_step, len(legs),
                           per_leg)
    n = min(FEWEST_POSITIONS, most)
    shortest = min(stated + (required or (longest,)))
    while True:
        targets, _ = _best_targets(lo, hi, n, required, stated)
        band, band_gap = resolved_band(targets, longest, shortest)
        unsampled = tuple(p for p, g in zip(stated, _gap_at(targets, stated), strict=True)
                          if g > LARGEST_PHASE_GAP)
        aliases = alias_level(targets, shortest)
        covered = not unsampled and _band_reached(band, required) and aliases <= ALIAS_LIMIT
        if not covered and n < most:
            n = min(most, max(n + 1, int(n * 1.12)))
            continue
        protocol = replace(protocol, scan_targets_mm=tuple(float(t) for t in targets))
        detection = detection_limits(protocol, machine, noise_mm, band, stated)
        wanted = targets_for_detection(detection, n)
        if wanted <= n or wanted > most or not timed:
            # reached, or beyond the budget's reach (or no budget in machine time to
            # grow within): the fewest that sample the band
            break
        n = wanted
    gaps = [band_gap, *[g for g in _gap_at(targets, stated) if g <= LARGEST_PHASE_GAP]]
    steps = len(reading_steps(protocol, machine))
    needed = len(legs) * (1 + (per_leg - 1) * wanted) if n < wanted <= MOST_POSITIONS else 0
    return ScanDesign(protocol, steps, seconds_per_step, budget_s, required, stated, band,
                      unsampled, max(gaps), noise_mm, detection, aliases, needed)


def _most_positions(budget_s: float | None, seconds_per_step: float, legs: int,
                    per_leg: int) -> int:
    """The most targets a leg's scan may have: those the budget of machine time holds
    (each target ``per_leg`` steps, each leg one more), none beyond ``MOST_POSITIONS``."""
    if budget_s is None:
        return MOST_POSITIONS
    return max(3, min(MOST_POSITIONS,
                      int((budget_s / seconds_per_step / legs - 1) // (per_leg - 1))))


def _band_reached(band: tuple[float, float], required: tuple[float, float] | None) -> bool:
    """The targets resolve the band of leads required (none: the stated leads only)."""
    return required is None or band[0] <= required[0] + 1e-9


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
    hysteresis' lost motion."""
    layout = planned_layout(protocol, machine)
    history = JointHistory.of(layout)
    sens = joint_sensitivity(vector(), layout, machine)
    s_r, s_s = sens.along()
    setting = s_s  # a gauge stays where it was set: its setting pose's sensitivity
    lo, hi = protocol.scan_targets_mm[0], protocol.scan_targets_mm[-1]
    offsets = s_r + setting  # each joint offset's column: the same shift everywhere
    # each encoder scale's: a shift in proportion to q (parameters.py's encoder_scale,
    # its column in the model's Jacobian up to the ppm unit), a smooth map's slope
    scales = s_r * layout.q_mm + setting * layout.setting_q_mm[layout.gauge]
    nuisance = _orthonormal(offsets)
    periods = sorted({*np.geomspace(band_mm[0], band_mm[1], 12).tolist(), *stated_mm})
    out: dict[str, float] = {}
    for leg in protocol.legs:
        a = AXES.index(leg)
        terms = {"lead_screw_cyclic": [MapTerm("lead_screw_cyclic", a, {"pitch_mm": p})
                                       for p in periods],
                 "screw_map": [MapTerm("screw_map", a, {"from_mm": lo, "to_mm": hi,
                                                        "knots": SMOOTH_KNOTS})],
                 "hysteresis": [MapTerm("hysteresis", a, {"length_mm": BUILD_UP_MM})]}
        for family, family_terms in terms.items():
            # a smooth map's line is the offset's and the scale's
            taken = _orthonormal(np.column_stack([offsets, scales[:, a]])) \
                if family_terms[0].kind.pointwise else nuisance
            worst = max(_amplitude_std(t, history, s_r[:, a], setting[:, a], layout.gauge,
                                       taken, lo, hi) for t in family_terms)
            out[family] = max(out.get(family, 0.0), DETECTION_SIGMAS * noise_mm * worst)
    return out


def _orthonormal(columns: np.ndarray) -> np.ndarray:
    u, s, _ = np.linalg.svd(columns, full_matrices=False)
    return u[:, s > s[0] * 1e-10]


def _amplitude_std(term: MapTerm, history: JointHistory, s_r: np.ndarray, s_s: np.ndarray,
                   gauge: np.ndarray, nuisance: np.ndarray, lo: float, hi: float) -> float:
    """The std of the term's amplitude per unit reading noise, the nuisance directions
    taken out: a cyclic error's amplitude (either quadrature: the larger), the rms over
    ``lo..hi`` of a smooth map's least visible shape less its line, a lost motion's
    value."""
    at_reading, at_setting = term.columns(history)
    cols = (at_reading * s_r[None] + at_setting[:, gauge] * s_s[None]).T  # (n, k)
    cols = cols - nuisance @ (nuisance.T @ cols)
    normal = cols.T @ cols
    if term.kind.pointwise:  # a smooth map: its values along q
        return _least_visible_rms(term, normal, lo, hi)
    try:
        cov = np.linalg.inv(normal)
    except np.linalg.LinAlgError:
        return math.inf
    return float(np.sqrt(max(float(np.max(np.diag(cov))), 0.0)))


def _least_visible_rms(term: MapTerm, normal: np.ndarray, lo: float, hi: float) -> float:
    """1 / sqrt of the smallest eigenvalue of ``normal`` (the map's coefficients, the
    offsets and scales taken out) against the Gram matrix of its shapes less their
    line over ``lo..hi``: the rms of the smooth map, its line apart, that the readings
    see least, per unit of their noise. The line's directions are the nuisance's (the
    offset's constant, the scale's slope): both matrices are blind to them, so the
    problem is solved on the shapes' rest."""
    grid = np.linspace(lo, hi, 101)
    basis = term.shape_of(grid, np.ones_like(grid), np.full_like(grid, np.inf),
                          np.zeros_like(grid))  # (k, 101)
    line = np.column_stack([np.ones_like(grid), grid])
    rest = basis - (line @ np.linalg.lstsq(line, basis.T, rcond=None)[0]).T
    gram = rest @ rest.T / len(grid)
    size, directions = np.linalg.eigh(gram)
    kept = size > size.max() * 1e-9
    whiten = directions[:, kept] / np.sqrt(size[kept])  # coefficients of unit-rms shapes
    seen = np.linalg.eigvalsh(whiten.T @ normal @ whiten)
    if seen[0] <= seen[-1] * 1e-10 or seen[0] <= 0.0:
        return math.inf  # a shape the readings do not see at all: too few targets
    return float(1.0 / math.sqrt(seen[0]))


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
    return replace(protocol, scan_step_mm=None, scan_from_mm=None, scan_to_mm=None,
                   scan_targets_mm=tuple(float(t) for t in between))
