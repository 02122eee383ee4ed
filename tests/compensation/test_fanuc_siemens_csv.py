"""The FANUC, SINUMERIK and CSV tables, each checked against its documentation.

FANUC (Series 0i-PB Parameter Manual B-63980EN/01, section 4, parameters 3620-3624
and its example; Series 16i/18i technical report A-77810E, bidirectional pitch error
compensation, parameters 3605#0, 3620-3627):
- 3621 = 3620 - (negative travel / interval 3624) + 1, 3622 = 3620 + (positive travel
  / interval) (the manual's example: reference 40, -400 mm at 50 mm -> 33);
- the value of position n is the compensation over the interval ending at n, an
  increment in detection units times the magnification 3623; the absolute
  compensation at a position is the sum of the increments from the reference
  position: zero there;
- bidirectional: a second table from 3626, and 3627 the absolute compensation at the
  reference position approached against the reference return direction.

SINUMERIK 840D sl Function Manual Extended Functions, K3 "Interpolatory compensation"
(6FC5397-1BP40-3BA1, 4.4.2; its example %_N_AX_EEC_INI, CHANDATA(1),
$AA_ENC_COMP[0,N,X1], _STEP, _MIN, _MAX, _IS_MODULO, M17); 808D: N = 0..199:
- equidistant points N = 0 .. (MAX - MIN) / STEP, at most as many as configured;
- the value at the reference point zero; "a positive compensation value causes the
  machine axis to move in the negative direction": the value is the error itself;
- MD32450 $MA_BACKLASH positive when the encoder leads the machine part.
"""

from __future__ import annotations

import re

import numpy as np
import pytest

from ogacq.compensation.fanuc import FanucOptions, fanuc_sheets, fanuc_tables
from ogacq.compensation.plain_csv import csv_tables
from ogacq.compensation.siemens import SiemensOptions, siemens_tables
from ogacq.compensation.tables import TableError
from tests.compensation.maps import screw_map


def test_fanuc_parameters_and_increments():
    m = screw_map()
    options = FanucOptions(interval_mm=2.0)
    (s,) = fanuc_sheets({"x": m}, options)
    # the position numbers from the travel and the interval, as the manual relates them
    assert s.ref_no - s.neg_no + 1 == 100 / 2.0 and s.pos_no - s.ref_no == 60 / 2.0
    assert 1 <= s.magnification <= 100 and s.unit_mm == pytest.approx(0.001 * s.magnification)
    assert all(abs(v) <= options.value_limit for v in s.values + s.neg_values)
    assert all(isinstance(v, int) for v in s.values)
    # incremental: summed from the reference position they give the absolute
    # compensation, minus the forward error, to within half a compensation unit
    values = np.array(s.values)
    k_ref = s.ref_no - s.neg_no  # index of the reference position's value
    for k, n in enumerate(range(s.neg_no, s.pos_no + 1)):
        absolute = values[k_ref + 1:k + 1].sum() if k >= k_ref else -values[k + 1:k_ref + 1].sum()
        expected = -m.error_mm(s.position_of(n), 1) / s.unit_mm
        assert abs(absolute - expected) <= 0.5 + 1e-9, n
    # reference position = the map's reference, where its error (forward) is zero
    assert s.position_of(s.ref_no) == m.reference_mm and m.error_mm(m.reference_mm, 1) == 0
    # the negative-direction table: the same positions, anchored by 3627 at the reference
    assert s.neg_dir_no == s.pos_no + 1
    assert s.ref_opposite == round(-m.error_mm(0.0, -1) / 0.001)
    text = fanuc_tables({"x": m}, options).files["fanuc.txt"]
    for number in (3620, 3621, 3622, 3623, 3624, 3626, 3627):
        assert re.search(rf"^\s+{number}\b", text, re.M), number
    assert "3605#0 bidirectional pitch error compensation = 1" in text
    assert "x before: A" in text


def test_fanuc_without_the_negative_table_gives_the_reversal_to_1851():
    m = screw_map(lost_mm=0.012)
    (s,) = fanuc_sheets({"x": m}, FanucOptions(bidirectional=False))
    assert s.neg_values == () and s.neg_dir_no is None
    assert s.backlash == 12  # detection units of 0.001 mm
    assert "1851 backlash compensating value" in fanuc_tables(
        {"x": m}, FanucOptions(bidirectional=False)).files["fanuc-backlash.txt"]


def test_fanuc_limits_refused_with_the_reason():
    with pytest.raises(TableError, match="more than the 10 allowed"):
        fanuc_sheets({"x": screw_map()}, FanucOptions(interval_mm=2.0, max_points=10))
    steep = screw_map(amplitude_mm=0.5, pitch_mm=4.0)  # 0.8 mm per mm at its steepest
    with pytest.raises(TableError, match="magnification"):
        fanuc_sheets({"x": steep}, FanucOptions(interval_mm=2.0, max_magnification=3))


def test_fanuc_axes_take_their_own_position_ranges():
    sheets = fanuc_sheets({"x": screw_map("x"), "y": screw_map("y")}, FanucOptions())
    x, y = sheets
    assert y.neg_no == x.pos_no + 1  # no overlap between the axes
    assert x.neg_dir_no is not None and y.neg_dir_no is not None
    assert x.neg_dir_no > y.pos_no and y.neg_dir_no == x.neg_dir_no + (x.pos_no - x.neg_no + 1)


def parse_siemens(text: str) -> dict:
    values: dict[int, float] = {}
    keys: dict[str, float] = {}
    for line in text.splitlines():
        found = re.match(r"\$AA_ENC_COMP\[0,(\d+),X1\]=(\S+)$", line)
        if found:
            values[int(found.group(1))] = float(found.group(2))
            continue
        found = re.match(r"\$AA_ENC_COMP_(STEP|MIN|MAX|IS_MODULO)\[0,X1\]=(\S+)$", line)
        if found:
            keys[found.group(1)] = float(found.group(2))
    return {"values": values, **keys}


def test_siemens_table_is_equidistant_and_zero_at_the_reference():
    m = screw_map()
    tables = siemens_tables({"x": m}, SiemensOptions(step_mm=2.0))
    text = tables.files["AX_EEC.INI"]
    lines = text.splitlines()
    assert lines[0] == "%_N_AX_EEC_INI" and "CHANDATA(1)" in lines and lines[-1] == "M17"
    for line in lines[1:-1]:
        assert line.startswith((";", "$", "CHANDATA")), line
    table = parse_siemens(text)
    n = len(table["values"])
    assert sorted(table["values"]) == list(range(n))  # N = 0, 1, ... without a gap
    assert n <= 200
    assert table["MAX"] - table["MIN"] == pytest.approx((n - 1) * table["STEP"])
    assert table["MIN"] <= -100.0 and table["MAX"] >= 60.0 and table["IS_MODULO"] == 0
    positions = table["MIN"] + table["STEP"] * np.arange(n)
    at_reference = int(np.argmin(np.abs(positions)))
    assert positions[at_reference] == pytest.approx(0.0)
    assert table["values"][at_reference] == 0.0  # zero at the reference point
    for k, q in enumerate(positions):  # the value is the error itself (MSEC's sign)
        assert table["values"][k] == pytest.approx(m.error_mm(q, 1), abs=1e-6)
    backlash = re.search(r"MD32450 \$MA_BACKLASH\[0\] = (\S+)", text)
    assert backlash and float(backlash.group(1)) == pytest.approx(0.012, abs=1e-6)


def test_siemens_point_limit_refused():
    with pytest.raises(TableError, match="more than the 50 configured"):
        siemens_tables({"x": screw_map()}, SiemensOptions(step_mm=1.0, max_points=50))


def test_csv_columns_and_sign():
    m = screw_map()
    text = csv_tables({"x": m}).files["compensation.csv"]
    rows = [line for line in text.splitlines() if not line.startswith("#")]
    assert rows[0] == ("axis,nominal_mm,forward_mm,reverse_mm,U_mm,correction_forward_mm,"
                       "correction_reverse_mm")
    data = [r.split(",") for r in rows[1:]]
    assert len(data) == len(m.positions_mm)
    nominals = [float(r[1]) for r in data]
    assert nominals == sorted(nominals)
    k = nominals.index(50.0)
    assert float(data[k][2]) == pytest.approx(m.error_mm(50.0, 1), abs=1e-6)
    assert float(data[k][4]) == pytest.approx(2 * 1.5 * 0.0008, abs=1e-6)  # k = 2
    # the sign said by the columns themselves: the correction is minus the error
    assert float(data[k][5]) == pytest.approx(-m.error_mm(50.0, 1), abs=1e-6)
    assert float(data[k][6]) == pytest.approx(-m.error_mm(50.0, -1), abs=1e-6)
