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
