"""'Validated' only where the validation's test would have seen the correction go wrong.

Found: ``ogacq calibrate --simulator`` on a 4 µm cyclic error of 20 mm lead on y
(seed 2) wrote a map of pitch 15.08 mm, which left 3.5 µm rms of 2.8, and ended
"validated" at the scan between the separating scan's targets (F(393, 396) = 1.04).
The papers' gauges of the y leg read across its line (a sensitivity of 0.03-0.13);
the other legs' gauges read along it, but only over the 16 mm the y joint moves
while x and z are driven. 98 % of what the validation sees of a 4 µm map is in that
stretch, where the wrong pitch fits as well as the right one; elsewhere an error up
to 64 µm would pass its test. These readings are the simulator's model of that scan
(the physics the devices run), the gauges' scatter of the run (0.8 µm)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from ogacq.calibration.sight import AxisSight, sights
from ogacq.calibration.validate import Judgement, outcome_of
from ogacq.identify.consistency import fit_verdict
from ogacq.identify.fit import fit
from ogacq.identify.noise import noise_for
from ogacq.model.axis_map import AxisMap
from ogacq.model.machine import PAPER_PROTOTYPE_DIGITAL as MACHINE
from ogacq.model.parameters import PARAM_SETS
from ogacq.protocol.plan import ProtocolConfig, planned_layout
from ogacq.protocol.scan_design import between_plan, design_scan
from ogacq.sim.readings import simulated_readings

OFFSETS = {"joint_offset.x": 0.4, "joint_offset.y": -0.3}
SCATTER_MM = 0.0008


@pytest.fixture(scope="module")
def validation():
    """The scan between the designed scan's targets, on a machine whose correction was
    right (offsets alone left), fitted as the validation fits it."""
    design = design_scan(MACHINE, ProtocolConfig(), noise_mm=0.0005)
    layout = planned_layout(between_plan(design.protocol, MACHINE), MACHINE)
    obs = simulated_readings(MACHINE, layout, OFFSETS, scatter_mm=SCATTER_MM,
                             step_mm=MACHINE.gauge_resolution_mm, seed=2)
    result = fit(obs, PARAM_SETS["offsets"], method="exact", weighting="gls",
                 noise=noise_for(obs))
    verdict = fit_verdict(result)
    assert verdict.consistent, verdict.describe()
    return result, verdict


def cyclic_map(amplitude_mm: float, pitch_mm: float = 20.0, axis: str = "y") -> AxisMap:
    q = np.arange(-101.0, 61.01, 0.5)
    e = tuple(float(v) for v in amplitude_mm * np.sin(2 * np.pi * q / pitch_mm))
    zeros = (0.0,) * len(q)
    return AxisMap(axis, tuple(float(v) for v in q), e, e, zeros, zeros)


def test_a_4_um_map_is_seen_only_where_the_other_legs_move_the_joint(validation):
    result, verdict = validation
    sight = sights({"y": cyclic_map(0.004)}, result, verdict, MACHINE)["y"]
    assert not sight.shown
    assert outcome_of(False, True, {"y": sight}) == "not shown"
    # seen in the stretch of the other legs' readings (y from about -16 to 0 mm) only
    edges = np.array(sight.edges_mm)
    at = {float(x): int(np.searchsorted(edges, x) - 1) for x in (-8.0, -60.0, 40.0)}
    assert sight.seen[at[-8.0]] and not sight.seen[at[-60.0]] and not sight.seen[at[40.0]]
    assert sum(sight.seen) == 1, sight.limits_mm
    # elsewhere an error twice the map's and more would pass the test
    assert min(v for v, s in zip(sight.limits_mm, sight.seen, strict=True) if not s) > 0.008
    said = sight.sentence()
    # its size less its mean over the table (a constant is the joint offset's)
    assert said.startswith("the y correction (3.8 µm about its mean) is not shown: the "
                           "validation sees an error of its size only over q from -11 to "
                           "+7 mm"), said
    assert "ISO 230-2" in said and "times the readings there" in said
    # what would show it: a scale along the actuator, as the campaign file declares it
    assert "an axis scale along the y actuator ([axis_scale.y]" in said


def test_a_correction_it_sees_everywhere_is_validated(validation):
    result, verdict = validation
    sight = sights({"y": cyclic_map(0.1)}, result, verdict, MACHINE)["y"]
    assert sight.shown, sight.limits_mm
    assert outcome_of(False, True, {"y": sight}) == "validated"
    # its limit said beside "validated"
    assert sight.sentence().startswith("the y correction (95 µm about its mean) is shown "
                                       "over the travel: an error of its size anywhere "
                                       "would fail the validation's test (limit at most "), \
        sight.sentence()
    # the limits are the correction's shape's, whatever its size: the same stretches
    small = sights({"y": cyclic_map(0.004)}, result, verdict, MACHINE)["y"]
    assert small.limits_mm == pytest.approx(sight.limits_mm, rel=1e-6)
    # a fit not within the noise is "improved", whatever it sees; reasons make it worse
    assert outcome_of(False, False, {"y": sight}) == "improved"
    assert outcome_of(True, True, {"y": sight}) == "worse"


def test_two_validations_show_what_either_sees():
    """The papers' postures and the scan between: a stretch is seen when either sees
    it, and the merged outcome is validated only when every stretch is."""
    edges = (-100.0, -20.0, 60.0)
    postures = AxisSight("y", 0.004, edges, (0.002, 0.05), 0.0009)
    scan = AxisSight("y", 0.004, edges, (0.03, 0.003), 0.0008)
    assert not postures.shown and not scan.shown
    both = postures.merged(scan)
    assert both.limits_mm == (0.002, 0.003) and both.shown
    blank = Judgement("not shown", (), {}, 1.0, 1.0, {}, {}, {}, {}, {})
    one, other = replace(blank, sight={"y": postures}), replace(blank, sight={"y": scan})
    assert one.merged(other).outcome == "validated"
    assert replace(one, outcome="improved").merged(other).outcome == "improved"
    # the verdict said with "improved" is the one not within the noise, whichever it is
    within, beyond = {"text": "within the gauge noise"}, {"text": "not within the noise"}
    for first, second in ((replace(one, verdict=within),
                           replace(other, outcome="improved", verdict=beyond)),
                          (replace(one, outcome="improved", verdict=beyond),
                           replace(other, verdict=within))):
        assert first.merged(second).verdict == beyond
    blind = AxisSight("y", 0.004, edges, (0.03, 0.05), 0.0008)
    merged = one.merged(replace(blank, sight={"y": blind}))
    assert merged.outcome == "not shown"
    assert merged.seen()[0].startswith("the y correction (4 µm about its mean) is not "
                                            "shown: the validation sees an error of its "
                                            "size only over q from -100 to -20 mm")
