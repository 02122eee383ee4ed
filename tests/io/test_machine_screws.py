"""The machine file's [screws]: each axis's lead and motor revolution, read, recorded
and written back (an implausible one is refused naming the key, the line and the unit:
tests/record/test_identity_files.py)."""

from __future__ import annotations

from ogacq.campaign.templates import machine_template
from ogacq.io.machine_file import machine_dict, machine_from_mapping, machine_text, read_machine
from ogacq.model.machine import Screw

GEOMETRY = """leg_length_mm = 310.25
rho_min_mm = -100.0
rho_max_mm = 60.0
gauge_resolution_mm = 0.001
"""
SCREWS = GEOMETRY + """[screws.x]
lead_mm = 5.0
[screws.z]
lead_mm = 4.0
revolution_mm = 2.0
"""


def test_screws_read_record_and_write_back(tmp_path):
    path = tmp_path / "m.toml"
    path.write_text(SCREWS)
    machine = read_machine(path)
    assert machine.screw("x") == Screw(5.0) and machine.screw("y") == Screw()
    assert machine.screw("z").periods_mm() == (2.0, 4.0)
    assert machine_from_mapping(machine_dict(machine)) == machine  # a session's header
    path.write_text(machine_text(machine, "again"))
    assert read_machine(path) == machine
    hash(machine)  # a plan's layout is cached by machine


def test_the_template_shows_the_screws_commented(tmp_path):
    text = machine_template()
    assert "# [screws.x]" in text and "# lead_mm = 5.0" in text
    path = tmp_path / "m.toml"
    path.write_text(text.replace("# [screws.x]", "[screws.x]")
                    .replace("# lead_mm = 5.0", "lead_mm = 5.0"))
    assert read_machine(path).screw("x").lead_mm == 5.0
