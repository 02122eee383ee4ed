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
    (3, 0, "abc", "t_s: 'abc' is not a number"),
    (4, 1, "0", "cycle: '0' is not a whole number >= 1"),
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


def test_numbers_python_reads_are_accepted(tmp_path, table_lines):
    path = _with(tmp_path, table_lines[2], 6, 10, " 1_000 ")
    assert read_readings(path).reading_mm[5] == 1000.0  # line 7: the sixth data row
