"""Drift flags: a change between successive calibrations larger than the root sum of
squares of their U (the E_n number above 1); with a U unknown, 2 std stand in and
the flag says so. And the plot draws every parameter with its U."""

from __future__ import annotations

import math

from ogacq.history.drift import changes
from ogacq.history.entries import Parameter
from ogacq.history.plot import write_history_plot
from ogacq.history.store import Calibration


def calibration(record_id: str, date: str, x: float, U: float | None,
                std: float | None = None) -> Calibration:
    return Calibration(record_id, date, "J. Martin", None, None, None, 20.0,
                       {"joint_offset.x": Parameter("joint_offset.x", x, None, U, 2.0, std)},
                       None, None)


def test_a_change_beyond_the_rss_of_both_u_is_flagged_and_one_within_is_not():
    history = [calibration("A", "2026-01-10T09:00:00", 0.420, 0.006),
               calibration("B", "2026-02-10T09:00:00", 0.428, 0.006),  # 8 um < 8.49 um
               calibration("C", "2026-03-10T09:00:00", 0.437, 0.006)]  # 9 um > 8.49 um
    found = changes(history)
    assert [(d.from_record, d.to_record, d.flagged) for d in found] == [
        ("A", "B", False), ("B", "C", True)]
    assert math.isclose(found[1].limit_mm, math.hypot(0.006, 0.006))
    assert math.isclose(found[1].change_mm, 0.009)
    assert found[1].basis == "U"
    assert found[1].describe().startswith("drift: joint_offset.x +0.0090 mm from B to C")


def test_without_u_twice_the_std_stands_in_and_says_so():
    found = changes([calibration("A", "2026-01-10", 0.420, None, std=0.002),
                     calibration("B", "2026-02-10", 0.430, 0.006)])
    assert found[0].basis == "std"
    assert math.isclose(found[0].limit_mm, math.hypot(0.004, 0.006))
    assert found[0].flagged  # 10 um > 7.2 um
    assert "U unknown: 2 x the fit's std used" in found[0].describe()
    # nothing to judge against: no change reported
    assert changes([calibration("A", "d1", 0.4, None), calibration("B", "d2", 0.5, None)]) == []


def test_the_plot_is_a_png(tmp_path):
    history = [calibration("A", "2026-01-10T09:00:00", 0.420, 0.006),
               calibration("B", "2026-02-10T09:00:00+01:00", 0.450, None, std=0.003)]
    path = write_history_plot(tmp_path / "h.png", "OG-1", history, changes(history))
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
