"""The readings CSV reader: converted column by column, each problem still reported
with its file, line and words, the first problem row first."""

import numpy as np
import pytest

from ogacq.io.errors import InputError
from ogacq.io.tables import read_readings, write_readings
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
