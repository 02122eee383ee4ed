"""The readings CSV reader: converted column by column, each problem still reported
with its file, line and words, the first problem row first."""

import numpy as np
import pytest

from ogacq.io.errors import InputError
from ogacq.io.tables import read_deviations, read_readings, sniff, write_readings
from ogacq.model.machine import PAPER_PROTOTYPE as M
from ogacq.protocol.plan import ProtocolConfig, planned_layout


@pytest.fixture
def table_lines(tmp_path):
    layout = planned_layout(ProtocolConfig(), M)
    values = np.random.default_rng(0).normal(size=len(layout))
    path = tmp_path / "readings.csv"
    write_readings(path, layout, values)
    return layout, values, path.read_text().splitlines()


def _with(tmp_path, lines, row, column, text):
    lines = list(lines)
    cells = lines[row].split(",")
    cells[column] = text
    lines[row] = ",".join(cells)
    path = tmp_path / "edited.csv"
    path.write_text("\n".join(lines) + "\n")
    return path


def test_round_trip_keeps_every_column(tmp_path, table_lines):
    layout, values, lines = table_lines
    table = read_readings(tmp_path / "readings.csv")
    assert np.array_equal(table.reading_mm, np.round(values, 6))
    assert np.array_equal(table.leg, layout.leg) and np.array_equal(table.cycle, layout.cycle)
    assert np.array_equal(table.approach, layout.approach)
    assert np.array_equal(table.lines, np.arange(2, len(layout) + 2))


@pytest.mark.parametrize(("row", "column", "text", "words"), [
    (3, 0, "abc", "t_s: 'abc' is not a number (ASCII digits, a sign, a point, an exponent)"),
    (4, 1, "0", "cycle: '0' is not a whole number 1..1000000"),
    (5, 2, "q", "leg: 'q' is not one of x, y, z"),
    (6, 10, "nan", "reading_mm: 'nan' is not a finite number"),
    (7, 11, "2", "approach_x: 2 is not -1, 0 or 1"),
    (9, 7, "1e400", "q_x: '1e400' is not a finite number"),
])
def test_a_bad_entry_is_named_with_its_line(tmp_path, table_lines, row, column, text, words):
    path = _with(tmp_path, table_lines[2], row, column, text)
    with pytest.raises(InputError) as caught:
        read_readings(path)
    assert str(caught.value) == f"{path}:{row + 1}: {words}"


def test_the_first_bad_row_is_reported(tmp_path, table_lines):
    path = _with(tmp_path, table_lines[2], 9, 10, "zz")
    path = _with(tmp_path, path.read_text().splitlines(), 4, 2, "w")
    with pytest.raises(InputError, match=r":5: leg: 'w'"):
        read_readings(path)


NOT_A_NUMBER = "is not a number (ASCII digits, a sign, a point, an exponent)"


@pytest.mark.parametrize(("column", "text", "words"), [
    # what Python's float() and int() take but a CSV number is not (issue 26's fuzz)
    (10, "１２", f"reading_mm: '１２' {NOT_A_NUMBER}"),  # fullwidth digits
    (7, "٣", f"q_x: '٣' {NOT_A_NUMBER}"),  # an Arabic-Indic digit
    (10, " 1_000 ", f"reading_mm: '1_000' {NOT_A_NUMBER}"),
    (1, "１２", "cycle: '１２' is not a whole number 1..1000000"),
    (1, "9" * 40, f"cycle: '{'9' * 40}' is not a whole number 1..1000000"),
    # finite, but beyond any machine: refused here, not as an OverflowError later
    (4, "1e308", "tcp_x: 1e308 is beyond 100000, more than any machine this tool calibrates"),
    (0, "9" * 40, f"t_s: {'9' * 40} is beyond 1e+09, more than any machine this tool "
                  "calibrates"),
])
def test_numbers_are_ascii_finite_and_bounded(tmp_path, table_lines, column, text, words):
    path = _with(tmp_path, table_lines[2], 6, column, text)
    with pytest.raises(InputError) as caught:
        read_readings(path)
    assert str(caught.value) == f"{path}:7: {words}"


def test_a_decimal_comma_is_refused_not_read_as_its_whole_part(tmp_path, table_lines):
    """Unquoted, "5,002" is two fields: 5 and a field beyond the header's, which a
    reader that ignores extra fields would drop; quoted, it is not a number."""
    for text, words in (("5,002", "row has 15 fields, the header 14 (a decimal comma? "
                                  "write 12.345)"),
                        ('"5,002"', f"reading_mm: '5,002' {NOT_A_NUMBER}")):
        path = _with(tmp_path, table_lines[2], 6, 10, text)
        with pytest.raises(InputError) as caught:
            read_readings(path)
        assert str(caught.value) == f"{path}:7: {words}"
    path = _with(tmp_path, table_lines[2], 6, 13, "1,")  # an empty trailing field: kept
    assert len(read_readings(path).reading_mm) == len(table_lines[0])


def test_numbers_as_csv_writes_them_are_accepted(tmp_path, table_lines):
    path = _with(tmp_path, table_lines[2], 6, 10, " +1.5e1 ")
    assert read_readings(path).reading_mm[5] == 15.0  # line 7: the sixth data row


TABLE_FIELDS = ("t_s", "cycle", "leg", "gauge_axis", "tcp_mm", "q_mm", "reading_mm", "approach",
                "lines")


@pytest.mark.parametrize("variant", ["as written", "CRLF", "no approach", "spaces", "upper case",
                                     "extra column"])
def test_the_plain_reader_gives_the_row_readers_table(tmp_path, table_lines, variant):
    """A plain file read whole by numpy gives, bit for bit, what the row reader gives."""
    from ogacq.io.tables import _plain_table, _table_by_rows

    _, _, lines = table_lines
    header, rows = lines[0], lines[1:]
    if variant == "no approach":
        header, rows = ",".join(header.split(",")[:11]), [",".join(r.split(",")[:11])
                                                          for r in rows]
    elif variant == "spaces":
        rows = [", ".join(r.split(",")) for r in rows]
    elif variant == "upper case":
        rows = [r.replace(",x,", ",X,") for r in rows]
    elif variant == "extra column":
        header, rows = header + ",note", [r + ",ok" for r in rows]
    newline = "\r\n" if variant == "CRLF" else "\n"
    text = newline.join([header, *rows]) + newline
    plain = _plain_table(text)
    assert plain is not None
    by_rows = _table_by_rows(tmp_path / "x.csv", text)
    for name in TABLE_FIELDS:
        a, b = getattr(plain, name), getattr(by_rows, name)
        assert (a is None and b is None) or (np.array_equal(a, b) and a.dtype == b.dtype), name


@pytest.mark.parametrize("row, column, text, words", [
    (5, 10, "1_000", "is not a number"),
    (7, 10, "１２", "is not a number"),
    (9, 1, "0", "cycle"),
    (11, 2, "w", "is not one of x, y, z"),
    (13, 10, "12,345", "decimal comma"),
    (15, 10, "nan", "not a finite number"),
])
def test_a_plain_file_with_a_bad_row_is_named_by_its_line(tmp_path, table_lines, row, column,
                                                          text, words):
    _, _, lines = table_lines
    path = _with(tmp_path, lines, row, column, text)
    with pytest.raises(InputError, match=words) as refused:
        read_readings(path)
    assert f":{row + 1}:" in str(refused.value)


def _written(tmp_path, lines, name="export.csv", separator=",", decimal="."):
    path = tmp_path / name
    path.write_text("\n".join(separator.join(cell.replace(".", decimal) for cell in line.split(","))
                              for line in lines) + "\n")
    return path


SEPARATED = ("{}: a readings CSV uses ',' between fields and '.' in numbers; export it again "
             "with those, or replace them")


@pytest.mark.parametrize(("separator", "decimal", "found"), [
    (";", ",", "fields are separated by ';' and decimals written with ',' (a spreadsheet's "
               "export in a locale writing decimal commas?)"),
    (";", ".", "fields are separated by ';' (a spreadsheet's export in a locale writing "
               "decimal commas?)"),
    ("\t", ".", "fields are separated by tabs (a spreadsheet's text export?)"),
])
def test_another_separator_is_said_not_guessed(tmp_path, table_lines, separator, decimal, found):
    """Neither read as the format (INTERCHANGE.md: ',' and '.'), nor refused as an
    "unrecognised header": what was found and what the format wants, by the sniffer and
    by the reader (``ogacq session import``)."""
    path = _written(tmp_path, table_lines[2], separator=separator, decimal=decimal)
    for read in (sniff, read_readings):
        with pytest.raises(InputError) as caught:
            read(path)
        assert str(caught.value) == f"{path}:1: {SEPARATED.format(found)}"


@pytest.mark.parametrize(("first", "words"), [
    ("# exported by DataLogger 2.1", "line 1 is a comment ('# exported by DataLogger 2.1'): the "
     "file begins with its header row"),
    ("T_S,CYCLE,LEG,GAUGE_AXIS,TCP_X,TCP_Y,TCP_Z,Q_X,Q_Y,Q_Z,READING_MM", "column 'T_S' is the "
     "format's 't_s' named otherwise: name it 't_s' (lowercase, the unit joined by '_')"),
    ("t_s,cycle,leg,gauge_axis,tcp_x,tcp_y,tcp_z,q_x,q_y,q_z,reading (mm)", "column 'reading "
     "(mm)' is the format's 'reading_mm' named otherwise: name it 'reading_mm'"),
])
def test_a_header_written_otherwise_is_named(tmp_path, table_lines, first, words):
    """By the reader, and by the sniffer where it cannot tell a readings CSV (a header
    with ``leg`` is one: its reader then names the column)."""
    lines = table_lines[2]
    path = _written(tmp_path, [first, *(lines if first.startswith("#") else lines[1:])])
    readers = (read_readings,) if "leg," in first else (sniff, read_readings)
    for read in readers:
        with pytest.raises(InputError) as caught:
            read(path)
        assert str(caught.value).startswith(f"{path}:1: {words}")


def test_a_row_pasted_twice_is_refused(tmp_path, table_lines):
    """Every row twice would count each reading as a repeat of the measurement (a
    smaller std from the same data); a gauge reads once at a time."""
    lines = table_lines[2]
    path = _written(tmp_path, lines + lines[5:7])
    gauge = "{}_{}".format(*lines[5].split(",")[3:1:-1])
    t_s = float(lines[5].split(",")[0])
    with pytest.raises(InputError) as caught:
        read_readings(path)
    assert str(caught.value) == (f"{path}:{len(lines) + 1}: gauge {gauge} read again at t_s "
                                 f"{t_s:g}, at the same posture, cycle and reading as at line "
                                 "6: a row is repeated (copied twice?); remove the copy")


def test_coarse_times_shared_by_two_postures_are_not_copies(tmp_path, table_lines):
    """Times written to the minute: a gauge read at two postures within one minute
    shares its t_s, which says nothing against the readings."""
    rows = [line.split(",") for line in table_lines[2]]
    coarse = [",".join(rows[0])] + [",".join([f"{60 * (float(r[0]) // 60):g}", *r[1:]])
                                    for r in rows[1:]]
    path = _written(tmp_path, coarse)
    table = read_readings(path)
    assert len(table.reading_mm) == len(rows) - 1
    assert len(set(table.t_s)) < len(table.t_s) // 2  # the times did coincide


def test_times_all_equal_record_none_and_rows_may_repeat(tmp_path, table_lines):
    """A hand-made file with t_s all 0: the Zero posture read twice a cycle gives the
    same row twice, a repeat of the measurement, not a copy."""
    rows = [line.split(",") for line in table_lines[2]]
    path = _written(tmp_path, [",".join(rows[0])] + [",".join(["0", *r[1:]]) for r in
                                                      rows[1:] + rows[1:3]])
    assert len(read_readings(path).reading_mm) == len(rows) + 1


@pytest.mark.parametrize("overflow", ["9999.999", "-9999.999"])
def test_a_gauges_overflow_value_is_named_by_its_line(tmp_path, table_lines, overflow):
    """A logger's overflow or error value among a gauge's readings: its line, before the
    span check (which names no line) refuses the whole gauge."""
    layout, values, lines = table_lines
    path = _with(tmp_path, lines, 9, 10, overflow)
    leg, gauge = layout.leg[8], layout.gauge_axis[8]
    others = np.sort(np.round(np.where(np.arange(len(values)) == 8, float(overflow), values),
                              6)[(layout.leg == leg) & (layout.gauge_axis == gauge)])
    median = (others[(len(others) - 1) // 2] + others[len(others) // 2]) / 2
    with pytest.raises(InputError) as caught:
        read_readings(path)
    assert str(caught.value) == (
        f"{path}:10: reading_mm: {overflow} is {abs(float(overflow) - median):g} mm from gauge "
        f"{'xyz'[gauge]}_{'xyz'[leg]}'s median reading ({median:g} mm), beyond the 50.8 mm "
        "travel of any indicator: a gauge's overflow or error value (read it again, or remove "
        "the row), or readings not in mm?")


def test_a_gauges_deviations_in_both_forms_are_refused(tmp_path):
    """dx_y is dx_y+ minus dx_y-: given beside them it counts the same readings twice."""
    path = tmp_path / "deviations.csv"
    path.write_text("name,value_mm\ndx_y+,0.1\ndy_x+,0.2\ndx_y-,0.05\ndx_y,0.05\n")
    with pytest.raises(InputError) as caught:
        read_deviations(path)
    assert str(caught.value) == (f"{path}:5: dx_y and dx_y+ (line 2) give the same gauge's "
                                 "deviations twice: dx_y (Max minus Min) is dx_y+ minus dx_y-; "
                                 "give a gauge's in one form")
    path.write_text("name,value_mm\ndx_y,0.05\ndy_x-,0.2\ndy_x,0.1\n")
    with pytest.raises(InputError, match=r":4: dy_x and dy_x- \(line 3\)"):
        read_deviations(path)
