"""What makes the calibration's separating measurement a scan: an error map among
an effect's alternatives is one (a few more postures could only say "a map"; the
table a controller needs is the scan's). Seen: a cyclic screw error on the papers'
protocol passed for a leg length with screw_map.x among its alternatives; the
postures plan then left the misfit "partly explained" and the calibration refused."""

from __future__ import annotations

import dataclasses

import numpy as np

from ogacq.calibration.separate import ambiguity, not_established, offsets_carried
from ogacq.diagnose.alternatives import Alternative
from ogacq.diagnose.diagnosis import EffectFound, diagnose
from tests.diagnose.campaigns import simulate


def with_effect(diagnosis, name: str, alternatives: tuple[str, ...]):
    found = EffectFound(name, 0.3, 0.05, [Alternative(a, 0.1, 0.5, np.zeros(1))
                                          for a in alternatives], [])
    return dataclasses.replace(diagnosis, effects=[found])


def test_an_error_map_among_the_alternatives_asks_for_a_scan():
    diagnosis = diagnose(simulate({}, seed=1))  # the papers' protocol, offsets only
    assert diagnosis.outcome == "consistent", diagnosis.outcome
    reasons, suspected = ambiguity(with_effect(diagnosis, "leg_length.x",
                                               ("backlash.x", "screw_map.x")))
    assert suspected and any("screw_map.x" in r and "scan" in r for r in reasons), reasons
    # a library alternative alone, on more postures per leg than the papers' three:
    # ambiguous, but the postures plan can separate it
    more = dataclasses.replace(diagnosis, postures_per_leg=5)
    reasons, suspected = ambiguity(with_effect(more, "squareness.xy", ("backlash.z",)))
    assert reasons and not suspected, reasons


def test_offsets_from_the_papers_three_postures_ask_for_a_scan():
    """A 4 mm lead reads alike at 0, +60 and -100 mm: an offsets-only diagnosis of the
    papers' protocol is consistent with it in place, and only positions between the
    postures show it (it was validated at the same postures, the error left)."""
    diagnosis = diagnose(simulate({}, seed=1))
    assert diagnosis.outcome == "consistent" and not diagnosis.effects
    reasons, suspected = ambiguity(diagnosis)
    assert suspected and any("3 positions per leg" in r and "between them" in r
                             for r in reasons), reasons
    more = dataclasses.replace(diagnosis, postures_per_leg=5)
    assert ambiguity(more) == ([], False)


def test_maps_the_scan_cannot_establish_leave_the_offsets_of_the_campaign():
    """A scan whose diagnosis is NOT within the noise, after a campaign whose is: its
    maps are said to be not established, and the procedure writes that campaign's
    offsets (it refused everything, the well-identified offsets included)."""
    from types import SimpleNamespace

    def verdict(consistent: bool):
        return SimpleNamespace(consistent=consistent, describe=lambda: "the verdict",
                               level=0.01)

    campaign = SimpleNamespace(final=verdict(True), maps=(), mapped=None)
    scan = SimpleNamespace(final=verdict(False), maps=(), mapped=None)
    said = not_established(scan, campaign)  # type: ignore[arg-type]
    assert said.startswith("error maps not established: the separating scan's diagnosis "
                           "(no map) fits the verdict; the offsets are those of the "
                           "calibration campaign"), said
    assert "--scan-minutes" in said
    assert "the same scan read again should this be the one time in 100" in said
    # the maps it found are named, though not tabulated while its fit is not within
    # the noise (seed 1's 4 µm lead on z, found to 1 %, was said "no map")
    found = SimpleNamespace(effects=[SimpleNamespace(name="lead_screw_cyclic.z")],
                            search=SimpleNamespace(unresolved=[]))
    said = not_established(SimpleNamespace(final=verdict(False), maps=(), mapped=found),
                           campaign)  # type: ignore[arg-type]
    assert "the separating scan's diagnosis (lead_screw_cyclic.z) fits the verdict" in said
    assert not_established(SimpleNamespace(final=verdict(True), maps=(),  # type: ignore
                                           mapped=None), campaign) == ""
    # neither within the noise: nothing better to fall back on
    assert not_established(scan, SimpleNamespace(final=verdict(False))) == ""  # type: ignore


def test_the_campaign_carries_its_offsets_alone_where_they_are_within_the_noise():
    """A leg length standing in for a lead's error (an alternative of screw_map.x) on
    three postures: where the scan cannot establish a map, the offsets written are the
    offsets-only model's (with the leg length they were not identifiable, and the
    write was refused); a campaign whose offsets alone are not within the noise (a
    squareness) keeps its whole diagnosis."""
    plain = diagnose(simulate({}, seed=1))
    with_length = with_effect(plain, "leg_length.x", ("backlash.x", "screw_map.x"))
    carried = offsets_carried(with_length)
    assert carried.effects == [] and carried.final is plain.base
    assert carried.final_fit is plain.base_fit and carried.maps == ()
    square = diagnose(simulate({"squareness.xy": 0.5}, seed=1))
    assert not square.base.consistent and offsets_carried(square) is square


def test_a_pitch_between_rival_peaks_leaves_the_maps_not_established():
    """The separating scan within the noise, but seeing a cyclic error whose pitch it
    does not resolve (20.4 or 34.7 mm): no map of it is written, and no smooth map in
    its place (seen: a 16 µm smooth map for a 4 µm error of 20 mm lead); the offsets
    are the calibration campaign's."""
    from types import SimpleNamespace

    from ogacq.diagnose.mapsearch import RIVALS

    term = SimpleNamespace(axis=1)
    seen = SimpleNamespace(term=term, unresolved=RIVALS + "20.39 and 34.73 mm fit alike")
    within = SimpleNamespace(consistent=True, describe=lambda: "within")
    scan = SimpleNamespace(final=within, maps=(),
                           mapped=SimpleNamespace(search=SimpleNamespace(unresolved=[seen])))
    said = not_established(scan, SimpleNamespace(final=within))  # type: ignore[arg-type]
    assert said.startswith("error maps not established: the separating scan sees a cyclic "
                           "error whose pitch it does not resolve (y axis: pitch unresolved: "
                           "20.39 and 34.73 mm"), said
    assert "positioning test along the axis" in said
