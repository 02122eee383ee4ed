"""A machine file's gauge step or repeatability that no indicator has (µm typed as mm)
is refused with the key, the line and the likely slip, before anything is planned."""

from __future__ import annotations

import pytest

from ogacq.errors import InputError
from ogacq.io.machine_file import read_machine

GEOMETRY = "leg_length_mm = 310.25\nrho_min_mm = -100.0\nrho_max_mm = 60.0\n"


@pytest.mark.parametrize("line, words", [
    ("gauge_resolution_mm = 10", "micrometres written as mm?"),
    ("gauge_resolution_mm = 0.001\ngauge_repeatability_mm = 2", "micrometres written as mm?"),
    ("gauge_resolution_mm = 1e-9", "is the unit mm?"),
])
def test_no_indicators_step_is_refused(tmp_path, line, words):
    path = tmp_path / "machine.toml"
    path.write_text(GEOMETRY + line + "\n")
    with pytest.raises(InputError, match="implausible") as refused:
        read_machine(path)
    message = str(refused.value)
    assert words in message and (":4:" in message or ":5:" in message), message


@pytest.mark.parametrize("step", ["0.01", "0.001", "0.0001", "0.1"])
def test_every_real_indicator_is_accepted(tmp_path, step):
    path = tmp_path / "machine.toml"
    path.write_text(GEOMETRY + f"gauge_resolution_mm = {step}\n")
    assert read_machine(path).gauge_resolution_mm == float(step)


@pytest.mark.parametrize("line, words", [
    # a blank name replaced the file's name by nothing: the run's record then named no
    # machine and `ogacq history add` failed with a traceback
    ('name = "  "', "name is blank: give the machine's name, or leave the key out for the "
                    "file's name"),
    ('serial = ""', "serial is blank: give the machine's serial number, or leave the key out"),
    ('name = "OG-1\\ncell 3"', "name = 'OG-1\\ncell 3' holds a control character (U+000A, a "
                               "line break): write it on one line"),
])
def test_a_name_the_history_cannot_show_is_refused(tmp_path, line, words):
    path = tmp_path / "machine.toml"
    path.write_text(GEOMETRY + "gauge_resolution_mm = 0.01\n" + line + "\n")
    with pytest.raises(InputError) as refused:
        read_machine(path)
    assert str(refused.value) == f"{path}:5: {words}"


def test_a_name_with_quotes_slashes_and_accents_is_kept_as_written(tmp_path):
    path = tmp_path / "machine.toml"
    path.write_text(GEOMETRY + 'gauge_resolution_mm = 0.01\nname = "OG \\"1\\"/cell 3 – Jürgen"\n',
                    encoding="utf-8")
    assert read_machine(path).name == 'OG "1"/cell 3 – Jürgen'
