"""ISO 230-2:2014 figures on numbers worked by hand (clause 3's definitions: Bi, B,
Ri = max(2si↑ + 2si↓ + |Bi|, Ri↑, Ri↓) with Ri↑ = 4si↑, E, M, A)."""

from __future__ import annotations

import pytest

from ogacq.compensation.iso230 import iso230_figures, map_figures
from ogacq.model.axis_map import AxisMap


def test_figures_worked_by_hand():
    # three targets; mean deviations (um) up 1, 4, -2 and down -1, 3, -5; s up 0.5, 1,
    # 0.5 and down 1, 0.5, 0.5
    f = iso230_figures("x", [0.0, 10.0, 20.0], [1e-3, 4e-3, -2e-3], [-1e-3, 3e-3, -5e-3],
                       [0.5e-3, 1e-3, 0.5e-3], [1e-3, 0.5e-3, 0.5e-3])
    um = 1e-3
    # Bi = 2, 1, 3 -> B 3, mean 2
    assert pytest.approx(3 * um) == f.B and f.B_mean == pytest.approx(2 * um)
    # Ri: max(2*0.5 + 2*1 + 2, 2, 4) = 5; max(2 + 1 + 1, 4, 2) = 4; max(1 + 1 + 3, 2, 2) = 5
    assert pytest.approx(5 * um) == f.R
    assert f.R_up == pytest.approx(4 * um) and f.R_down == pytest.approx(4 * um)
    # E: max of all means 4, min -5 -> 9; E up 6, down 8; M: means 0, 3.5, -3.5 -> 7
    assert pytest.approx(9 * um) == f.E and f.E_up == pytest.approx(6 * um)
    assert f.E_down == pytest.approx(8 * um) and pytest.approx(7 * um) == f.M
    # A: max(x + 2s) = max(2, 6, -1, 1, 4, -4) = 6; min(x - 2s) = min(0, 2, -3, -3, 2, -6) = -6
    assert pytest.approx(12 * um) == f.A
    assert f.A_up == pytest.approx((6 - (-3)) * um)  # max(2, 6, -1) - min(0, 2, -3)
    assert f.A_down == pytest.approx((4 - (-6)) * um)  # max(1, 4, -4) - min(-3, 2, -6)


def test_a_map_with_only_lost_motion():
    """A constant lost motion b: B = b on every target, E = b, M = 0; with zero u,
    R = b and A = b."""
    q = (-10.0, 0.0, 10.0)
    m = AxisMap("y", q, (0.0,) * 3, (0.02,) * 3, (0.0,) * 3, (0.0,) * 3)
    f = map_figures(m)
    assert pytest.approx(0.02) == f.B  # max |Bi|
    assert f.B_mean == pytest.approx(-0.02)  # x̄↑ - x̄↓: the map's e+ - e- = -b
    assert pytest.approx(0.02) == f.E and pytest.approx(0.0) == f.M
    assert pytest.approx(0.02) == f.R and pytest.approx(0.02) == f.A
