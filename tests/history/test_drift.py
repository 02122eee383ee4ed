"""Drift flags: a change between successive calibrations larger than the root sum of
squares of their U (the E_n number above 1); with a U unknown, 2 std stand in and
the flag says so. And the plot draws every parameter with its U."""

from __future__ import annotations

import dataclasses
import math

from ogacq.history.drift import changes, controller_changes, written_by_record
from ogacq.history.entries import Parameter
from ogacq.history.plot import history_figure, recorded_calibrations, write_history_plot
from ogacq.history.store import Calibration, OffsetState


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


def state(operation: str, stage: str, x: float, record: str, status: str = "done",
          action: str = "write") -> OffsetState:
    return OffsetState(f"S-{operation}-{stage}", stage, None, None, operation, action, status,
                       "cia402", {"x": x, "y": 0.0, "z": 0.0}, record, None)


def test_a_write_back_is_no_drift_and_a_change_from_the_state_as_left_is():
    """The offsets written from A's session set the machine's x to about zero: B (its
    validation) is judged against that, as left, not against A as found."""
    written = written_by_record([state("w1", "before", 0.0, "A"),
                                 state("w1", "after", -0.907, "A"),
                                 state("w2", "before", 0.0, "A", status="failed"),
                                 state("w2", "after", 5.0, "A", status="failed")])
    assert written == {"A": {"joint_offset.x": -0.907, "joint_offset.y": 0.0,
                             "joint_offset.z": 0.0}}
    history = [calibration("A", "2026-01-10", 0.907, 0.006),
               calibration("B", "2026-01-11", 0.002, 0.006),   # validated: no drift
               calibration("C", "2026-03-10", 0.020, 0.006)]   # 18 um from B: a drift
    found = changes(history, written)
    assert [(d.to_record, round(d.change_mm, 6), d.flagged) for d in found] == [
        ("B", 0.002, False), ("C", 0.018, True)]
    assert "from the state as left" in found[0].describe()
    # as found (no write-back known), the validation would read as a 0.905 mm drift
    assert changes(history)[0].flagged


def test_the_plot_marks_the_write_back(tmp_path):
    history = [calibration("A", "2026-01-10T09:00:00", 0.907, 0.006),
               calibration("B", "2026-01-11T09:00:00", 0.002, 0.006)]
    written = {"A": {"joint_offset.x": -0.907}}
    figure = history_figure("OG-1", history, changes(history, written), written)
    labels = [t.get_text() for t in figure.axes[0].get_legend().get_texts()]
    assert "as left by a write-back" in labels and "change > U of the change" not in labels


def test_a_records_history_is_drawn_by_the_same_figure_with_itself_marked():
    """The report's figure: a record's earlier calibrations then itself, read as the
    history reads records; a length in mm as the tables state it (it was drawn in µm),
    a squareness in its own mrad; no U and no std is said on the panel, not drawn as a
    zero bar."""
    def results(x: float, U: float | None, squareness: float | None = None) -> dict:
        out = {"joint_offset": {"x": {"value_mm": x, "U_mm": U, "std_mm": None}}}
        if squareness is not None:
            out["squareness"] = {"xy": {"value_mm": squareness, "U_mm": 0.01}}
        return out

    record = {"id": "R-3", "date": "2026-03-10T09:00:00+01:00",
              "results": results(0.425, 0.006, 0.2),
              "history": [{"id": "R-1", "date": "2026-01-10T09:00:00", "results":
                           results(0.420, None)},
                          {"id": "R-2", "date": "2026-02-10T09:00:00", "results":
                           results(0.428, 0.006)}]}
    record["history"].reverse()  # a caller's history in any order: drawn oldest first
    calibrations = recorded_calibrations(record)
    assert [c.record_id for c in calibrations] == ["R-1", "R-2", "R-3"]
    figure = history_figure("this machine", calibrations, current="R-3")
    offset, squareness = figure.axes[:2]
    assert offset.get_ylabel() == "joint_offset.x\n(mm)"
    assert squareness.get_ylabel() == "squareness.xy\n(mrad)"
    labels = [t.get_text() for t in offset.get_legend().get_texts()]
    assert labels == ["this calibration", "value ± U"]
    assert [t.get_text() for t in offset.texts] == ["U not evaluated"]  # R-1 only
    drawn = offset.lines[0].get_ydata()  # the current calibration's ring, in mm
    assert list(drawn) == [0.425]
    figure.canvas.draw()  # the axis's numbers as the table's, no offset text beside them
    assert offset.yaxis.get_offset_text().get_text() == ""


def in_force(c: Calibration, x: float) -> Calibration:
    return dataclasses.replace(c, offsets_in_force_mm={"x": x, "y": 0.0, "z": 0.0})


def test_a_controller_reset_outside_ogacq_is_named_and_no_drift_of_the_machine():
    """A's offsets written (0 -> -0.907), B validates them; then the drive is replaced
    and holds 0 again: C finds the 0.907 mm of A. Judged by the offsets in force, the
    machine did not move; the controller's change is named instead."""
    written = written_by_record([state("w1", "before", 0.0, "A"),
                                 state("w1", "after", -0.907, "A")])
    history = [in_force(calibration("A", "2026-01-10", 0.907, 0.006), 0.0),
               in_force(calibration("B", "2026-01-11", 0.002, 0.006), -0.907),
               in_force(calibration("C", "2026-03-10", 0.909, 0.006), 0.0)]
    found = changes(history, written)
    assert [(d.to_record, round(d.change_mm, 6), d.flagged) for d in found] == [
        ("B", 0.002, False), ("C", 0.0, False)]
    assert math.isclose(found[1].controller_moved_mm, 0.907)
    assert "the controller's moved +0.9070 mm" in found[1].describe()
    moved = controller_changes(history, written)
    assert [(c.from_record, c.to_record) for c in moved] == [("B", "C")]
    assert math.isclose(moved[0].unexplained_mm["joint_offset.x"], 0.907)
    assert "changed outside ogacq between B and C (x +0.9070 mm" in moved[0].describe()
    # by the write-backs alone, C would read as a 0.907 mm drift
    bare = [dataclasses.replace(c, offsets_in_force_mm=None) for c in history]
    assert changes(bare, written)[1].flagged and controller_changes(bare, written) == []


def test_a_real_drift_stays_flagged_when_the_offsets_in_force_are_known():
    history = [in_force(calibration("A", "2026-01-10", 0.907, 0.006), 0.0),
               in_force(calibration("B", "2026-03-10", 0.925, 0.006), 0.0)]  # 18 um
    found = changes(history)
    assert found[0].flagged and math.isclose(found[0].change_mm, 0.018)
    assert controller_changes(history) == []
