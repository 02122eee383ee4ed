"""The drive's step in the figures: every "as left" figure stated beside its bound with
one count of the drive (a target is a whole count), a map finer than a count said so."""

from __future__ import annotations

import numpy as np
import pytest

from ogacq.calibration.drive_step import (
    drive_step_mm,
    finer_than_drive,
    predicted_with_step,
    with_drive_step,
)
from ogacq.model.axis_map import AxisMap


def cyclic_map(amplitude_mm: float) -> AxisMap:
    q = np.linspace(-100.0, 60.0, 321)
    e = tuple(float(v) for v in amplitude_mm * np.sin(2 * np.pi * q / 5.0))
    u = tuple(0.0002 for _ in q)
    return AxisMap("x", tuple(float(v) for v in q), e, e, u, u)


def test_the_cia402_drive_steps_ten_micrometres():
    # drivers/axes/profiles/cia402.toml: counts_per_mm = 100 (the position user unit)
    assert drive_step_mm("cia402") == pytest.approx(0.01)


def test_a_map_within_one_count_is_said_to_be_finer_than_the_drive():
    said = finer_than_drive({"x": cyclic_map(0.004)}, 0.01)
    # its grid of 0.5 mm reaches 3.8 of the 4 um crests
    assert len(said) == 1 and "at most 3.8 µm" in said[0] and "10 µm a count" in said[0]
    assert "up to 5 µm" in said[0]
    assert finer_than_drive({"x": cyclic_map(0.004)}, 0.001) == []  # a 1 um drive


def test_the_figures_after_carry_one_count_beside_them():
    after = with_drive_step({"x": {"A_mm": 0.00109, "E_mm": 0.00029, "R_mm": 0.0008}}, 0.01)
    x = after["x"]
    assert x["drive_step_mm"] == 0.01
    assert x["A_with_step_mm"] == pytest.approx(0.01109)
    assert x["E_with_step_mm"] == pytest.approx(0.01029)
    assert "R_with_step_mm" not in x  # a scatter: the rounding is the same every time


def test_the_predicted_figures_say_the_drive_step_they_leave_out():
    said = predicted_with_step(0.01)
    assert "whole count of the drive (10 µm)" in said and "A, B, E and M" in said
