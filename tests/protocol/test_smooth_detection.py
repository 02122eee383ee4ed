"""The designed scan's detection limit for a smooth screw map: stated for the map's
shape beyond a constant and a slope (the joint offset's and the encoder scale's), the
least visible one, checked against what the simulator's readings show; 1.5 um reached
in 40 minutes by targets placed where the map is seen, the bound no placing beats said
where a budget falls short; the display's rounding counted as the repeats share it; and
a smooth map of a few micrometres found on the design."""

from __future__ import annotations

import dataclasses
import math
from functools import lru_cache

import numpy as np
import pytest

from ogacq.diagnose.diagnosis import diagnose
from ogacq.model.machine import PAPER_PROTOTYPE_DIGITAL
from ogacq.model.measurement import predict_jacobian
from ogacq.model.parameters import AXES, indices, vector
from ogacq.protocol.plan import ProtocolConfig, planned_layout
from ogacq.protocol.scan_design import (
    ScanDesign,
    design_scan,
    detection_limits,
    sampled_band,
    smooth_allocation,
    stratified_targets,
)
from ogacq.sim.physics import true_coordinates
from ogacq.sim.readings import simulated_readings
from ogacq.sim.truth import SCREW_MAP_UNIT_MM, ScrewMap, SimTruth

MACHINE = PAPER_PROTOTYPE_DIGITAL
NOISE_MM = 0.0005
STEP_S = 5.5


@lru_cache(maxsize=2)  # a design is a pure function of the machine and the budget
def _design(minutes: float) -> ScanDesign:
    return design_scan(MACHINE, ProtocolConfig(settle_s=1.0), noise_mm=NOISE_MM,
                       seconds_per_step=STEP_S, budget_s=minutes * 60)


def _beyond_line(q: np.ndarray, e: np.ndarray) -> np.ndarray:
    return e - np.polyval(np.polyfit(q, e, 1), q)


def test_the_targets_placed_where_the_smooth_map_is_seen_and_the_bound_said():
    """Issue 37's target, 1.5 um at a 0.5 um gauge in at most 450 reading steps, is beyond
    what any placing of targets along the legs' axes reaches: a joint's error along its
    own axis reaches its leg's gauges at 0.13 of it at most, the other legs' gauges see
    it over -16..0 mm only, and each gauge's zero takes its constant there. The 34
    targets placed where the map is seen (every lead from 2 to 40 mm still at 4 phases)
    reach 1.87 um where equal strata reach 2.35; no placing of them goes below 1.76 um
    (37 targets, 447 steps: 1.68 um), which the design says, with what 1.5 um needs."""
    design = _design(40)
    assert design.steps == 411 and design.duration_s <= 40 * 60
    assert 0.0018 <= design.detection_mm["screw_map"] <= 0.0019
    assert design.complete and design.pitch_band_mm == (2.0, 40.0) and design.alias_level <= 0.5
    assert design.worst_gap <= 0.25
    # the same count in equal strata (the design without a budget in machine time)
    equal = design_scan(MACHINE, ProtocolConfig(settle_s=1.0), noise_mm=NOISE_MM)
    assert equal.steps == design.steps and equal.targets_mm != design.targets_mm
    assert equal.detection_mm["screw_map"] > 0.0023
    assert 0.00174 <= design.smooth_bound_mm <= 0.00177
    text = " ".join(design.lines())
    assert "beyond a constant and a slope (the joint offset's and the encoder scale's)" in text
    assert "no placing of 34 targets along the travel sees the smooth map below 1.8 µm" in text
    assert "1.5 µm in every family would need about 675 reading steps (62 min" in text
    assert design.to_json()["detection_target_steps"] == 675
    # a budget that holds them gets them
    longer = _design(62)
    assert longer.steps == 675 and longer.detection_mm["screw_map"] <= 0.0015
    assert longer.target_steps == 0 and longer.smooth_bound_mm == 0.0
    assert "would need" not in " ".join(longer.lines())


def test_no_placing_of_the_targets_beats_the_bound_the_design_states():
    """The bound the design states (the dual of the E-optimal allocation) lies below the
    exact limit of every placing of its count tried: the design's (within 10 % of it),
    equal strata, all near the ends, at random, the allocation's strata alone."""
    design = _design(40)
    bound = design.smooth_bound_mm
    n = len(design.targets_mm)
    assert bound <= design.detection_mm["screw_map"] <= 1.1 * bound
    lo, hi = design.targets_mm[0], design.targets_mm[-1]
    allocation = smooth_allocation(dataclasses.replace(design.protocol, scan_targets_mm=(
        lo, hi)), MACHINE, NOISE_MM)
    rng = np.random.default_rng(3)
    placings = [np.linspace(lo, hi, n),
                np.concatenate([np.linspace(lo, lo + 20, n // 2), np.linspace(hi - 20, hi,
                                                                              n - n // 2)]),
                np.sort(np.concatenate([[lo, hi], rng.uniform(lo, hi, n - 2)])),
                stratified_targets(lo, hi, n, 0, allocation.strata_edges(1.0, lo, hi))]
    for targets in placings:
        plan = dataclasses.replace(design.protocol, scan_targets_mm=tuple(
            float(t) for t in np.round(targets, 3)))
        exact = detection_limits(plan, MACHINE, NOISE_MM, (2.0, 40.0))["screw_map"]
        assert exact >= bound, (targets, exact, bound)


def test_a_display_of_10_um_counts_a_postures_cycles_once():
    """On a 10 um display a gauge repeating to 0.5 um rounds a posture's cycles alike: the
    limits count them once (the diagnosis's own covariance, c(sigma, s)), not each
    reading. Were the same 2.4 um independent (a 1 um display), the two cycles would
    halve the variance: the limits come out sqrt 2 smaller."""
    design = _design(40)
    dial = dataclasses.replace(MACHINE, gauge_resolution_mm=0.01)
    band = design.pitch_band_mm
    rounded = detection_limits(design.protocol, dial, 0.0024, band)
    independent = detection_limits(design.protocol, MACHINE, 0.0024, band)
    for family in ("screw_map", "lead_screw_cyclic"):
        assert rounded[family] / independent[family] == pytest.approx(math.sqrt(2), rel=0.05)
    said = design_scan(dial, ProtocolConfig(settle_s=1.0), noise_mm=0.0024,
                       seconds_per_step=STEP_S, budget_s=40 * 60)
    text = " ".join(said.lines())
    assert ("most of it the 0.01 mm display's rounding, which a posture's cycles share: they "
            "count about once") in text
    # beyond any count the design tries, what 1.5 um would take is said all the same
    assert said.target_steps > 12_000 and "1.5 µm in every family would need about" in text
    assert "gauges of a finer display would need far fewer" in text
    assert said.smooth_bound_mm > 0.0015 and "no placing of 34 targets" in text


def test_no_cubic_map_beyond_its_line_is_seen_less_than_the_limit_says():
    """The limit is the least visible shape of the spline: every cubic (in its span)
    scaled to the limit's rms beyond its line stands out of the readings by 3 noise
    once the joint offsets, the axis's encoder scale and each gauge's zero have taken
    what they can (the simulator's exact geometry, the model's Jacobian for the
    nuisance)."""
    design = _design(40)
    limit = design.detection_mm["screw_map"]
    layout = planned_layout(design.protocol, MACHINE)
    straight = true_coordinates(SimTruth(vector()), layout, MACHINE)
    travel = np.linspace(design.targets_mm[0], design.targets_mm[-1], 401)
    seen = []
    for axis, name in enumerate(AXES):
        nuisance = np.column_stack([predict_jacobian(vector()[None], layout, MACHINE, indices(
            ("joint_offset.x", "joint_offset.y", "joint_offset.z",
             f"encoder_scale.{name}")))[0], np.eye(layout.n_gauges)[layout.gauge]])
        for coefficients in ((0.0, 1.0), (0.0, 0.0, 1.0), (0.0, 1.0, 1.5), (0.0, -1.0, 0.7)):
            shape = ScrewMap(coefficients)
            rms = np.sqrt(np.mean(_beyond_line(travel, shape.error_mm(travel)) ** 2))
            bent = ScrewMap(tuple(c * limit / rms for c in coefficients))
            signal = true_coordinates(SimTruth(vector(), screw_map={axis: bent}), layout,
                                      MACHINE) - straight
            rest = signal - nuisance @ np.linalg.lstsq(nuisance, signal, rcond=None)[0]
            seen.append(np.linalg.norm(rest) / NOISE_MM)
    # the second order of a few um on 310 mm legs is 1e-7 of them; a cubic is seen at
    # 5.8 to 9.6 noise: the least visible shape wiggles at the knots' spacing
    assert min(seen) >= 3.0 * 0.99


def test_a_smooth_map_of_3_um_on_one_axis_is_found_on_the_designed_scan():
    """Two Gaussian bumps on y (+7.5 and -5.25 um, 15 mm wide at q = -50 and +20 mm; 2.9
    um rms beyond their line), read at the designed targets with a 0.5 um gauge: a
    smooth map on y alone, within the noise, leaving under half of it. (At 2 um rms the
    bench, bench/bench_smooth_map.py, finds it in 10 seeds of 15: at the limit.)"""
    design = _design(40)
    q = np.linspace(MACHINE.rho_min_mm, MACHINE.rho_max_mm, 321)
    bumps = (7.5 * np.exp(-0.5 * ((q + 50) / 15) ** 2)
             - 5.25 * np.exp(-0.5 * ((q - 20) / 15) ** 2)) / 1e3
    powers = np.column_stack([(q / SCREW_MAP_UNIT_MM) ** k for k in range(1, 11)])
    smooth = ScrewMap(tuple(np.linalg.lstsq(powers, bumps - np.interp(0.0, q, bumps),
                                            rcond=None)[0]))
    truth = SimTruth(vector({"joint_offset.x": 0.4, "joint_offset.y": -0.3}),
                     screw_map={1: smooth})
    obs = simulated_readings(MACHINE, planned_layout(design.protocol, MACHINE), truth,
                             scatter_mm=NOISE_MM, step_mm=0.0001, seed=1)
    found = diagnose(obs, pitch_band_mm=sampled_band(design.protocol, MACHINE))
    assert found.final.consistent
    assert [(m.axis, m.source.split(" (")[0]) for m in found.maps] == [("y", "smooth screw map")]
    inside = q[(q >= design.targets_mm[0]) & (q <= design.targets_mm[-1])]
    truth_rest = _beyond_line(inside, smooth.error_mm(inside))
    mapped = (found.maps[0].error_mm(inside, 1) + found.maps[0].error_mm(inside, -1)) / 2
    left = truth_rest - _beyond_line(inside, mapped)
    assert np.sqrt(np.mean(truth_rest ** 2)) > 0.0028
    assert np.sqrt(np.mean(left ** 2)) < 0.5 * np.sqrt(np.mean(truth_rest ** 2))


def test_a_design_without_its_machine_time_grows_no_further_than_the_band_needs():
    """Where a reading step's time is not known, the budget bounds nothing: the design
    keeps the fewest equal strata that sample the band and says what 1.5 um would need."""
    design = design_scan(MACHINE, ProtocolConfig(settle_s=1.0), noise_mm=NOISE_MM,
                         seconds_per_step=0.0, budget_s=40 * 60)
    assert design.steps == 411 and design.target_steps == 1059
    assert "1.5 µm in every family would need about 1059 reading steps" in " ".join(
        design.lines())
