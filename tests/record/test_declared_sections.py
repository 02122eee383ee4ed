"""The record's inner sections declared once (ogacq.record.declared): read from the
JSON the procedure writes and written back byte for byte; a section holding something
else than declared is refused with the key named, never shown as something else."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from ogacq.compensation.export import AxisVerdict, Exported
from ogacq.compensation.iso230 import map_figures
from ogacq.model.axis_map import AxisMap
from ogacq.record.calibration_record import CalibrationRecord
from ogacq.record.compensation import CompensationSection
from ogacq.record.declared import RecordSectionError, read, written

X_MAP = AxisMap("x", (-100.0, 0.0, 60.0), (0.0, 0.004, 0.011), (0.002, 0.006, 0.012),
                (0.001,) * 3, (0.001,) * 3, source="encoder scale +408 ± 35 ppm (k = 2)")


def calibrate_compensation() -> dict[str, Any]:
    """A compensation section as ``ogacq calibrate`` writes it (procedure._end), its
    figures and tables from the writers that make them."""
    figures = map_figures(X_MAP)
    return {
        "procedure": "C-20261128-fafde9", "outcome": "improved", "reason": "better",
        "writes": {"offsets": "write-81bd009e", "maps": "maps-write-db716973"},
        "restores": {}, "maps": {"x": {"source": X_MAP.source, "checksum": X_MAP.checksum()}},
        "compensated": ["encoder_scale.x"], "uncompensated": ["squareness.xy"],
        "iso230_2": {"before": {"x": figures.to_json()}, "after": {}},
        "offsets": {"corrected_mm": {"x": 0.012, "y": -0.003, "z": 0}, "left_mm": None},
        "tables": [Exported("linuxcnc", (Path("tables/linuxcnc/x.comp"),),
                            {"x": {"before": figures.to_json()}}, None,
                            {"x": AxisVerdict("x", True, None, figures)}).to_json(),
                   Exported("fanuc", (), {}, "too many points").to_json()]}


def test_a_calibrate_section_reads_typed_and_writes_back_byte_for_byte():
    given = calibrate_compensation()
    section = read(CompensationSection, given, "compensation")
    assert section.maps["x"].checksum == X_MAP.checksum()
    assert section.iso230_2.before["x"].A_mm == pytest.approx(map_figures(X_MAP).A, abs=1e-7)
    assert section.offsets is not None and section.offsets.left_mm is None
    assert section.offsets.corrected_mm["z"] == 0  # an int stays one: written as 0, not 0.0
    assert section.tables[0].files == ("tables/linuxcnc/x.comp",)
    assert section.tables[1].problem == "too many points"
    assert json.dumps(written(section)) == json.dumps(given)


def test_keys_it_does_not_declare_and_their_order_are_kept():
    given = {"note": "added by hand", **calibrate_compensation(), "later": [1, {"a": 2}]}
    del given["offsets"]  # an older record: the key absent, and not written back
    section = read(CompensationSection, given, "compensation")
    assert section.offsets is None and section.extra == {"note": "added by hand",
                                                         "later": [1, {"a": 2}]}
    assert json.dumps(written(section)) == json.dumps(given)


@pytest.mark.parametrize(("change", "key", "problem"), [
    (lambda c: c.pop("outcome"), "compensation.outcome", "is missing"),
    (lambda c: c.update(maps={"x": "encoder scale"}), "compensation.maps.x",
     "must be an object, got text"),
    (lambda c: c["tables"][1].update(files="x.comp"), "compensation.tables[1].files",
     "must be a list, got text"),
    (lambda c: c["iso230_2"]["before"]["x"].update(A_mm="71"),
     "compensation.iso230_2.before.x.A_mm", "must be a number, got text"),
    (lambda c: c["offsets"]["corrected_mm"].update(y=True),
     "compensation.offsets.corrected_mm.y", "must be a number, got true or false"),
])
def test_a_section_of_another_shape_names_the_key(change, key, problem):
    given = calibrate_compensation()
    change(given)
    with pytest.raises(RecordSectionError) as raised:
        read(CompensationSection, given, "compensation")
    assert raised.value.key == key
    assert str(raised.value).startswith(f"the calibration record's {key} {problem}")
    assert raised.value.exit_code == 2  # an InputError: one line, exit 2


def test_the_record_gives_its_compensation_typed_and_as_written():
    given = calibrate_compensation()
    record = CalibrationRecord.from_json({"format": "ogacq-record/1", "compensation": given})
    assert record.compensation_section == read(CompensationSection, given, "compensation")
    assert record.to_json()["compensation"] == given
    assert CalibrationRecord.from_json({"format": "ogacq-record/1"}).compensation_section \
        is None
    with pytest.raises(RecordSectionError, match="compensation must be an object, got a list"):
        _ = CalibrationRecord.from_json({"compensation": [given]}).compensation_section
