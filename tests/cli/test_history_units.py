"""One unit for one quantity in ``ogacq history`` (issue 38.8): the table of identified
values and its figure (``--plot``) state each parameter in the same unit; the table
was in mm and the figure in µm."""

from __future__ import annotations

from ogacq.cli.render_history import print_calibrations
from ogacq.history.entries import Parameter
from ogacq.history.plot import history_figure
from ogacq.history.store import Calibration, Machine


def calibration(record_id: str, date: str, parameters: dict[str, float]) -> Calibration:
    return Calibration(record_id, date, "J. Martin", None, None, None, 20.0,
                       {n: Parameter(n, v, None, 0.004, 2.0) for n, v in parameters.items()},
                       None, None)


def _printed(calibrations, capsys, monkeypatch) -> str:
    monkeypatch.setenv("COLUMNS", "160")
    print_calibrations(Machine(1, "OG-1", "SIM-1"), "h.sqlite", calibrations, [], [])
    return " ".join(capsys.readouterr().out.split())  # a title wraps at its table's width


def _units_of(figure) -> list[str]:
    return [ax.get_ylabel().split("\n")[1] for ax in figure.axes]


def test_joint_offsets_are_in_mm_in_the_table_and_on_its_figure(capsys, monkeypatch):
    history = [calibration("A", "2026-01-10T09:00", {"joint_offset.x": 0.4201}),
               calibration("B", "2026-02-10T09:00", {"joint_offset.x": 0.4283})]
    out = _printed(history, capsys, monkeypatch)
    assert "identified joint offsets (mm ± U, k = 2;" in out
    assert "+0.4201 ± 0.0040" in out
    assert _units_of(history_figure("OG-1", history)) == ["(mm)"]


def test_a_parameter_of_another_unit_says_it_in_its_column_as_on_its_panel(capsys,
                                                                          monkeypatch):
    history = [calibration("A", "2026-01-10T09:00",
                           {"joint_offset.x": 0.4201, "squareness.xy": 0.2})]
    out = _printed(history, capsys, monkeypatch)
    assert "(value ± U, k = 2;" in out and "mm ± U" not in out
    assert "x (mm)" in out and "squareness.xy (mrad)" in out
    assert _units_of(history_figure("OG-1", history)) == ["(mm)", "(mrad)"]


def test_a_validation_after_a_diagnosis_that_found_effects_says_its_offsets_are_biased(
        capsys, monkeypatch):
    """Issue 38.4 in the history: a validation after a write-back whose campaign's
    diagnosis found a squareness listed its joint offsets fitted alone (-0.025 mm, a
    write-back that looked failed), without a word. The note says they are biased by the
    effect, and which command judges them with it carried over; a diagnosis that found
    nothing beside the offsets adds no words."""
    import dataclasses

    from ogacq.cli import render_history
    from ogacq.history.store import Event, Machine
    from tests.history.test_drift import calibration

    monkeypatch.setenv("COLUMNS", "400")
    before = dataclasses.replace(calibration("A", "2026-01-10", 0.300, 0.006),
                                 session_path="/shop/s.jsonl")
    after = dataclasses.replace(calibration("B", "2026-01-10", -0.025, 0.006),
                                session_path="/shop/s-2.jsonl")
    written = {"A": {"joint_offset.x": -0.3}}
    diagnosis = {"final": {"consistent": True},
                 "effects": [{"effect": "squareness", "where": "xy", "value": 0.5}]}

    def notes(found: dict) -> str:
        render_history.print_calibrations(
            Machine(1, "OG-1", "S1"), "h.sqlite", [before, after], [],
            [Event("diagnosis", "A", "2026-01-10", None, "/shop/s.jsonl", found)], written)
        return " ".join(capsys.readouterr().out.split())

    said = notes(diagnosis)
    assert ("B validates the write-back made from A: its joint offsets below are fitted "
            "alone, biased by squareness.xy, which the diagnosis of A found and a "
            "write-back leaves on the machine; `ogacq report /shop/s.jsonl --after "
            "/shop/s-2.jsonl` judges it with them carried over") in said
    plain = notes({"final": {"consistent": True}, "effects": []})
    assert "B validates the write-back made from A " in plain + " " and "biased" not in plain
