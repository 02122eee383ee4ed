"""The error-map type the diagnosis hands to the compensation: its sign convention,
interpolation, JSON round trip, checksum and refusals."""

from __future__ import annotations

import json

import numpy as np
import pytest

from ogacq.errors import InputError
from ogacq.model.axis_map import AxisMap


def backlash_map(b: float = 0.02) -> AxisMap:
    # a joint that stops short by b/2 on each side (MODEL's rho - approach b / 2)
    return AxisMap("x", (-100.0, 0.0, 60.0), (-b / 2,) * 3, (b / 2,) * 3,
                   (0.001,) * 3, (0.001,) * 3, source="backlash")


def test_backlash_sign_and_unknown_side():
    m = backlash_map()
    assert m.error_mm(10.0, 1) == pytest.approx(-0.01)
    assert m.error_mm(10.0, -1) == pytest.approx(0.01)
    assert m.error_mm(10.0, 0) == pytest.approx(0.0)


def test_linear_between_points_and_held_outside():
    m = AxisMap("y", (0.0, 10.0), (0.0, 0.01), (0.0, 0.01), (0.0, 0.0), (0.0, 0.0))
    assert m.error_mm(np.array([5.0, -3.0, 12.0]), 1).tolist() == pytest.approx(
        [0.005, 0.0, 0.01])


def test_corrected_target_lands_on_the_target():
    # a 5 um, 5 mm pitch screw error: the corrected command lands within 1e-7 mm
    q = np.arange(-100.0, 60.01, 0.5)
    e = 0.005 * np.sin(2 * np.pi * q / 5.0)
    m = AxisMap("z", tuple(q), tuple(e), tuple(e), (0.0,) * len(q), (0.0,) * len(q))
    for target in (-73.3, 0.2, 41.7):
        command = m.corrected_target(target, 1)
        assert command + float(m.error_mm(command, 1)) == pytest.approx(target, abs=2e-5)


def test_json_round_trip_and_checksum():
    m = backlash_map()
    again = AxisMap.from_json(json.loads(json.dumps(m.to_json())))
    assert again == m and again.checksum() == m.checksum()
    assert backlash_map(0.03).checksum() != m.checksum()


@pytest.mark.parametrize("change, words", [
    ({"positions_mm": [0.0, 0.0, 1.0]}, "ascending"),
    ({"forward_mm": [0.0, 1.0]}, "2 values for 3"),
    ({"axis": "w"}, "axis must be"),
    ({"u_reverse_mm": [0.0, -1.0, 0.0]}, "negative"),
    ({"reverse_mm": [0.0, "1", 0.0]}, "not a number"),
    ({"format": "other/1"}, "not an ogacq-axis-map/1"),
])
def test_bad_maps_are_refused_by_name(change, words):
    data = {**backlash_map().to_json(), **change}
    with pytest.raises(InputError, match=words):
        AxisMap.from_json(data, "maps.json")
