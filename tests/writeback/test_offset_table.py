"""The software offset table and the campaign file key that names it."""

from __future__ import annotations

import math

import pytest

from ogacq.campaign.campaign_file import read_campaign
from ogacq.io.errors import InputError
from ogacq.model.parameters import AXES
from ogacq.writeback.table import read_offset_table, write_offset_table
from tests.campaign.conftest import MACHINE

GAUGES = "".join(f'[[gauges]]\ngauge = "{k}"\nprotocol = "mitutoyo-01a"\nport = "/dev/ttyUSB{n}"\n'
                 for n, k in enumerate(("y_x", "z_x", "x_y", "z_y", "x_z", "y_z")))


def test_round_trip_exact_and_missing_means_zero(tmp_path):
    path = tmp_path / "offsets.toml"
    assert read_offset_table(path).offsets_mm == dict.fromkeys(AXES, 0.0)
    assert not read_offset_table(path).exists
    values = {"x": 0.1 + 0.2, "y": -1.4617919999999, "z": 1e-7}
    table = write_offset_table(path, values, session="/runs/s.jsonl")
    assert table.exists and table.offsets_mm == values  # bit for bit
    assert table.about["session"] == "/runs/s.jsonl" and table.about["action"] == "write"
    with pytest.raises(ValueError, match="finite"):
        write_offset_table(path, {**values, "y": math.nan})
    assert read_offset_table(path).offsets_mm == values  # the old file stands


@pytest.mark.parametrize(("text", "line", "words"), [
    ('[joint_offset_mm]\nx = 0.1\ny = 0.2\nw = 0.3\n', 4, "unknown axis 'w'"),
    ('[joint_offset_mm]\nx = 0.1\ny = "0.2"\nz = 0.3\n', 3, "joint_offset_mm.y must be a number"),
    ('[joint_offset_mm]\nx = 0.1\ny = 0.2\n', 1, "[joint_offset_mm] needs 'z'"),
    ('colour = 1\n[joint_offset_mm]\nx = 0.1\ny = 0.2\nz = 0.3\n', 1, "unknown key 'colour'"),
    ('format = "other/9"\n', 1, "format"),
    ('[joint_offset_mm\n', 1, "not valid TOML"),
])
def test_bad_table_names_the_file_and_line(tmp_path, text, line, words):
    path = tmp_path / "offsets.toml"
    path.write_text(text)
    with pytest.raises(InputError) as bad:
        read_offset_table(path)
    assert f"{path}:{line}:" in str(bad.value) and words in str(bad.value)


def campaign_text(controller: str) -> str:
    return 'machine = "machine.toml"\n' + controller + GAUGES


def test_campaign_offsets_file_resolved_against_the_campaign_file(tmp_path):
    (tmp_path / "machine.toml").write_text(MACHINE)
    path = tmp_path / "campaign.toml"
    path.write_text(campaign_text('[controller]\nprofile = "iai-pcon"\nport = "/dev/ttyUSB9"\n'
                                  'offsets_file = "cfg/offsets.toml"\n'))
    spec = read_campaign(path).controller
    assert spec.offsets_file == (tmp_path / "cfg" / "offsets.toml").resolve()
    path.write_text(campaign_text('[controller]\nprofile = "iai-pcon"\nport = "/dev/ttyUSB9"\n'))
    assert read_campaign(path).controller.offsets_file is None


@pytest.mark.parametrize(("controller", "line", "words"), [
    ('[controller]\nprofile = "cia402"\nport = "127.0.0.1:1"\noffsets_file = "o.toml"\n', 5,
     "keeps the joint offsets in the controller (home_offset)"),
    ('[controller]\nprofile = "iai-pcon"\nport = "/dev/ttyUSB9"\noffsets_file = 3\n', 5,
     "offsets_file must be text"),
])
def test_campaign_offsets_file_refused_with_line(tmp_path, controller, line, words):
    (tmp_path / "machine.toml").write_text(MACHINE)
    path = tmp_path / "campaign.toml"
    path.write_text(campaign_text(controller))
    with pytest.raises(InputError) as bad:
        read_campaign(path)
    assert f"{path}:{line}:" in str(bad.value) and words in str(bad.value)


def test_an_offset_beyond_the_axis_travel_moves_nothing(tmp_path):
    """A table hand-edited or taken from another machine: an offset longer than the
    whole travel would send every target past the soft limits the joint coordinates
    were checked against. Refused naming the file, before any link is opened."""
    from ogacq.campaign.station import open_controller

    (tmp_path / "machine.toml").write_text(MACHINE)
    path = tmp_path / "campaign.toml"
    path.write_text(campaign_text('[controller]\nprofile = "iai-pcon"\nport = "/dev/ttyUSB9"\n'
                                  'offsets_file = "offsets.toml"\n'))
    write_offset_table(tmp_path / "offsets.toml", {"x": 0.25, "y": 9999.999, "z": -1.5})
    with pytest.raises(InputError) as bad, open_controller(read_campaign(path).controller):
        pass
    assert str(bad.value).startswith(f"{tmp_path / 'offsets.toml'}: joint_offset_mm.y = "
                                     "9999.999 mm is more than the y axis's whole travel")
