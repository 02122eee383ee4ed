"""One map per axis, each error corrected once; and ogacq's own correction of targets."""

from __future__ import annotations

import numpy as np
import pytest

from ogacq.compensation.applied import TargetCorrection
from ogacq.compensation.combine import compensation
from ogacq.compensation.effects import EffectValue, effect_maps
from ogacq.compensation.linuxcnc import linuxcnc_tables
from ogacq.model.axis_map import AxisMap
from ogacq.model.machine import PAPER_PROTOTYPE_DIGITAL

MACHINE = PAPER_PROTOTYPE_DIGITAL


def test_library_effects_as_a_map_and_the_constant_to_the_offset():
    """e = s q - a b / 2 (the model's encoder scale and lost motion), zero at 0 forward:
    the map holds s q and the lost motion on the reverse side; -b/2 goes to the offset."""
    effects = {"encoder_scale.x": EffectValue("encoder_scale.x", 400.0, 20.0),
               "backlash.x": EffectValue("backlash.x", 0.02, 0.001)}
    maps = effect_maps(effects, MACHINE)
    m = maps["x"].axis_map
    assert maps["x"].offset_shift_mm == pytest.approx(-0.01)
    assert m.error_mm(50.0, 1) == pytest.approx(400e-6 * 50)
    assert m.error_mm(50.0, -1) == pytest.approx(400e-6 * 50 + 0.02)
    assert m.error_mm(0.0, 1) == 0.0
    # what the model predicts once the offset carries the constant: the same errors
    for q in (-80.0, 0.0, 40.0):
        for a in (1, -1):
            model = 400e-6 * q - a * 0.02 / 2
            assert m.error_mm(q, a) + maps["x"].offset_shift_mm == pytest.approx(model)
    assert m.u_forward_mm[0] == pytest.approx(100 * 20e-6)  # |q - ref| u_s at q = -100
    # said as the record states a result: U = 2 u to two significant digits, the value
    # to its decimal place, k stated (JCGM 100:2008 7.2.6; it was "+400.0 ± 20.0 ppm")
    assert m.source == "encoder scale +400 ± 40 ppm (k = 2), backlash 20.0 ± 2.0 µm (k = 2)"


def test_a_diagnosis_map_with_the_model_s_trend_is_not_corrected_twice():
    q = np.linspace(-100.0, 60.0, 33)
    screw = 0.004 * np.sin(2 * np.pi * q / 10.0)
    trend = 300e-6 * q
    diagnosed = AxisMap("x", tuple(q), tuple(screw + trend + 0.003),
                        tuple(screw + trend + 0.003), (0.0005,) * 33, (0.0005,) * 33,
                        source="screw")
    effects = {"encoder_scale.x": EffectValue("encoder_scale.x", 300.0, 10.0)}
    out = compensation([diagnosed], effect_maps(effects, MACHINE), effects)["x"]
    assert "encoder_scale.x" in out.removed  # the map was not orthogonal to it
    # the total holds the trend once (the model's) and the screw, zero at the reference
    expected = trend + screw - (0.004 * np.sin(0.0))
    np.testing.assert_allclose(out.axis_map.error_mm(q, 1), expected, atol=2e-4)
    assert out.axis_map.error_mm(0.0, 1) == 0.0
    # a map already orthogonal to it (excludes it) is taken as it is
    orthogonal = AxisMap("x", tuple(q), tuple(screw), tuple(screw), (0.0005,) * 33,
                         (0.0005,) * 33, excludes=("encoder_scale.x",))
    kept = compensation([orthogonal], effect_maps(effects, MACHINE), effects)["x"]
    assert kept.removed == ()
    np.testing.assert_allclose(kept.axis_map.error_mm(q, 1), trend + screw, atol=1e-12)


def test_maps_in_force_add_to_what_the_campaign_found():
    q = (-100.0, 0.0, 60.0)
    in_force = AxisMap("x", q, (-0.03, 0.0, 0.018), (-0.03, 0.0, 0.018), (0.001,) * 3,
                       (0.001,) * 3)
    effects = {"encoder_scale.x": EffectValue("encoder_scale.x", 20.0, 5.0)}
    out = compensation([], effect_maps(effects, MACHINE), effects, {"x": in_force})["x"]
    assert out.axis_map.error_mm(60.0, 1) == pytest.approx(0.018 + 20e-6 * 60)
    assert out.offset_shift_mm == 0.0


def test_targets_corrected_by_the_side_they_are_approached_from():
    q = (-100.0, 0.0, 60.0)
    lost = AxisMap("x", q, (0.0,) * 3, (0.02,) * 3, (0.0,) * 3, (0.0,) * 3)
    c = TargetCorrection({"x": lost}, travel_mm=(-100.0, 60.0))
    assert c.command((0.0, 5.0, 5.0)) == pytest.approx((-0.01, 5.0, 5.0))  # no side: mean
    assert c.command((10.0, 5.0, 5.0))[0] == pytest.approx(10.0)  # moving +: e+ = 0
    assert c.command((-20.0, 5.0, 5.0))[0] == pytest.approx(-20.02)  # moving -: e- = b
    assert c.command((-20.0, 0.0, 5.0))[0] == pytest.approx(-20.02)  # x kept its side
    assert c.nominal((-20.0, 0.0, 5.0), (-20.02, 0.0, 5.0)) == (-20.0, 0.0, 5.0)
    # at the end of the travel the target is held, and the reading says where it landed
    assert c.command((-100.0, 0.0, 5.0))[0] == -100.0
    assert c.nominal((-100.0, 0.0, 5.0), (-100.0, 0.0, 5.0))[0] == pytest.approx(-99.98)


def test_positions_a_rounding_apart_are_one_point_of_the_sum():
    """A diagnosis map over positions rounded to 1e-9 mm and a library map over the same
    span unrounded (what ``ogacq calibrate`` gave: ``-100.098353198`` and
    ``-100.09835319823402``) add up on one point there, not two: LinuxCNC refuses a
    nominal that does not increase ("compensation values must increase", the motion
    module's EMCMOT_SET_JOINT_COMP) and the tables would list it twice."""
    span = np.linspace(-100.0983531982340, 56.1, 41)
    rounded = np.round(span, 9)
    assert rounded[0] != span[0]  # the case: a nanometre's fraction apart
    diagnosed = AxisMap("x", tuple(rounded), (0.001,) * 41, (0.001,) * 41, (0.0005,) * 41,
                        (0.0005,) * 41, source="screw", excludes=("encoder_scale.x",))
    effects = {"encoder_scale.x": EffectValue("encoder_scale.x", 300.0, 10.0)}
    maps = effect_maps(effects, MACHINE, spans={"x": (float(span[0]), float(span[-1]))})
    out = compensation([diagnosed], maps, effects)["x"].axis_map
    assert np.min(np.diff(out.positions_mm)) > 1e-6
    nominals = [float(line.split()[0]) for line in
                linuxcnc_tables({"x": out}).files["x.comp"].splitlines()]
    assert all(b > a for a, b in zip(nominals, nominals[1:], strict=False))
