"""The validation scan grown where a written periodic map would not be seen.

Found: the designed scan's 5 mm lead on x (bench/designed_scan.py), its map right over
the whole travel (0.48 µm rms of 2.83 left), ended "not shown" beyond q = -64 mm: the
validation between the scan's targets tests the map's pitch on too few readings far
from its reference, where "about 2 times the readings there" would have shown it."""

from __future__ import annotations

import numpy as np

from ogacq.calibration.resolving import loose_references, resolving_plan
from ogacq.calibration.validation_design import predicted_sight, validation_plan
from ogacq.diagnose.diagnosis import diagnose
from ogacq.model.error_maps import axis_map, terms_json
from ogacq.model.families.base import MapTerm
from ogacq.model.machine import PAPER_PROTOTYPE_DIGITAL as MACHINE
from ogacq.model.parameters import vector
from ogacq.protocol.plan import ProtocolConfig, planned_layout, reading_steps, scan_targets
from ogacq.protocol.scan_design import between_plan, design_scan, sampled_band
from ogacq.sim.readings import simulated_readings
from ogacq.sim.truth import LeadScrewError, SimTruth

NOISE_MM = 0.0009  # the scatter the designed scan's run measured


def lead_map(pitch_mm: float = 5.0) -> dict:
    term = MapTerm("lead_screw_cyclic", 0, {"pitch_mm": pitch_mm}, 0.4)
    return {"x": axis_map([term], [np.array([0.0045, 0.0])], np.zeros((2, 2)), -100.1, 60.1,
                          pitch_mm / 20, source="cyclic", extra={"terms": terms_json([term])})}


def test_the_validation_grows_at_the_travels_far_end_until_it_sees_the_period():
    scan = design_scan(MACHINE, ProtocolConfig(), noise_mm=0.0005).protocol
    between = between_plan(scan, MACHINE)
    plan = validation_plan(scan, lead_map(), MACHINE, NOISE_MM)
    added = sorted(set(plan.scan_targets_mm) - set(between.scan_targets_mm))
    assert added and set(between.scan_targets_mm) <= set(plan.scan_targets_mm)
    # where the pitch is tested least: the far end from the map's reference (0.4 mm)
    assert min(added) < -80.0 and np.median(added) < -40.0, added
    # never where the scan read
    assert not set(added) & set(scan_targets(scan, MACHINE))
    assert not predicted_sight(between, lead_map(), MACHINE, NOISE_MM)["x"].shown
    assert predicted_sight(plan, lead_map(), MACHINE, NOISE_MM)["x"].shown
    # within the machine time given
    steps = len(reading_steps(between, MACHINE))
    assert validation_plan(scan, lead_map(), MACHINE, NOISE_MM, steps) == between


def test_no_periodic_map_no_growth():
    scan = design_scan(MACHINE, ProtocolConfig(), noise_mm=0.0005).protocol
    assert validation_plan(scan, {}, MACHINE, NOISE_MM) == between_plan(scan, MACHINE)


def test_a_pitch_left_unresolved_is_read_at_other_phases_in_every_gap():
    scan = design_scan(MACHINE, ProtocolConfig(), noise_mm=0.0005).protocol
    scanned = np.asarray(scan_targets(scan, MACHINE))
    more = np.asarray(resolving_plan(scan, MACHINE).scan_targets_mm)
    assert len(more) == len(scanned) - 1
    share = (more - scanned[:-1]) / np.diff(scanned)
    assert share.min() >= 0.11 and share.max() <= 0.19
    # clear of the validation's targets between the scan's (0.3-0.7 of each gap)
    assert not set(more) & set(between_plan(scan, MACHINE).scan_targets_mm)


def test_a_loose_pitch_reads_the_gaps_far_from_its_reference_twice():
    scan = design_scan(MACHINE, ProtocolConfig(), noise_mm=0.0005).protocol
    scanned = np.asarray(scan_targets(scan, MACHINE))
    once = np.asarray(resolving_plan(scan, MACHINE).scan_targets_mm)
    twice = np.asarray(resolving_plan(scan, MACHINE, [0.4]).scan_targets_mm)
    added = np.setdiff1d(twice, once)
    farthest = max(abs(scanned[0] - 0.4), abs(scanned[-1] - 0.4))
    assert len(added) > 10 and np.all(np.abs(added - 0.4) >= 0.5 * farthest - 5.0)
    # each at 21-29 % of its gap
    gap = np.searchsorted(scanned, added) - 1
    share = (added - scanned[gap]) / (scanned[gap + 1] - scanned[gap])
    assert share.min() >= 0.21 and share.max() <= 0.29


def test_a_lead_longer_than_half_the_stretch_seen_directly_grows_nothing():
    """A 20 mm lead is seen directly over 18 mm, less than two of its periods: its
    period never shows it, and readings added far off would be machine time spent for
    nothing."""
    scan = design_scan(MACHINE, ProtocolConfig(), noise_mm=0.0005).protocol
    plan = validation_plan(scan, lead_map(20.0), MACHINE, NOISE_MM)
    assert plan == between_plan(scan, MACHINE)


def test_a_pitch_is_loose_for_the_travel_where_the_readings_leave_it_so():
    """A 4 µm lead of 6.35 mm read by the designed scan at 0.5 µm on the 1 µm display:
    its map's uncertainty, the pitch's slip over the 100 mm from its reference included
    (6.33 +- 0.03 mm), is beyond half its size far off, so the scan is read again; a
    machine without the lead has no map to read again for."""
    scan = design_scan(MACHINE, ProtocolConfig(), noise_mm=0.0005).protocol
    layout = planned_layout(scan, MACHINE)
    band = sampled_band(scan, MACHINE)
    loose = {}
    for amplitude in (0.004, 0.0):
        truth = SimTruth(vector({}), lead_screw={1: LeadScrewError(amplitude, 6.35)}
                         if amplitude else {})
        obs = simulated_readings(MACHINE, layout, truth, scatter_mm=0.0005,
                                 step_mm=MACHINE.gauge_resolution_mm, seed=3)
        found = diagnose(obs, pitch_band_mm=band)
        assert [m.axis for m in found.maps] == (["y"] if amplitude else []), found.maps
        loose[amplitude] = loose_references(found, MACHINE)
    assert loose == {0.004: [0.0], 0.0: []}


def test_a_scan_whose_fit_is_not_within_the_noise_is_read_again_at_other_phases():
    """At the 1 % level a right model fails once in a hundred scans (seen: a 4 µm lead
    on z found to 1 %, combined p = 0.009): its maps were then not established and the
    run refused. Its gaps are now read at other phases, as for a pitch left
    unresolved, and both judged together; a scan within the noise, with no pitch
    unresolved nor loose, reads nothing more."""
    from types import SimpleNamespace

    from ogacq.calibration.resolving import why_read_more

    def scanned(consistent: bool):
        search = SimpleNamespace(unresolved=[])
        return SimpleNamespace(final=SimpleNamespace(consistent=consistent),
                               mapped=SimpleNamespace(search=search, fit=None), maps=())

    assert why_read_more(scanned(False), MACHINE) == (  # type: ignore[arg-type]
        "the scan's fit is NOT within the gauge noise", [])
    assert why_read_more(scanned(True), MACHINE) is None  # type: ignore[arg-type]
