"""Identity and traceability keys of the machine and campaign files: good files
read back, bad ones are refused naming the file, the line and the problem."""

from __future__ import annotations

import datetime

import pytest

from ogacq.campaign.campaign_file import campaign_text, read_campaign
from ogacq.errors import InputError
from ogacq.io.machine_file import machine_dict, machine_from_mapping, read_machine
from ogacq.model.instrument import Instrument

GEOMETRY = """leg_length_mm = 310.25
rho_min_mm = -100.0
rho_max_mm = 60.0
gauge_resolution_mm = 0.001
"""
IDENTIFIED = """name = "OG-1 cell 3"
serial = "OG-2026-0017"
""" + GEOMETRY + """leg_expansion_ppm_per_k = 11.5
[tolerances]
deviation_mm = 0.020
"dx_y+" = 0.015
decision_rule = "simple"
"""

GAUGE = """[[gauges]]
gauge = "y_x"
make = "Mitutoyo"
model = "543-790B"
serial = "12345678"
certificate = "DKD-K-12345 2026-0412"
calibrated = 2026-03-01
due = 2027-03-01
uncertainty_mm = 0.0015
uncertainty_k = 2.0
"""
CAMPAIGN = """machine = "machine.toml"
operator = "J. Martin"
session = "s.jsonl"
[simulator]
seed = 3
date = 2026-01-10T09:00:00
ambient_c = 23.5
[environment]
ambient_c = 20.4
machine_c = 21.0
[override]
expired_gauges = "re-checked against gauge blocks on 2026-01-09"
""" + GAUGE


def _write(tmp_path, name, text):
    path = tmp_path / name
    path.write_text(text)
    return path


def test_machine_identity_and_tolerances_read_and_round_trip(tmp_path):
    machine = read_machine(_write(tmp_path, "m.toml", IDENTIFIED))
    assert (machine.name, machine.serial) == ("OG-1 cell 3", "OG-2026-0017")
    assert machine.leg_expansion_ppm_per_k == 11.5
    assert machine.tolerances.of("dx_y+") == 0.015 and machine.tolerances.of("dz_y-") == 0.02
    assert machine.tolerances.decision_rule == "simple"
    # the session header's machine reads back the same machine
    assert machine_from_mapping(machine_dict(machine)) == machine
    # a file without the new keys reads as before, named after its file
    plain = read_machine(_write(tmp_path, "cell4.toml", GEOMETRY))
    assert (plain.name, plain.serial, plain.tolerances) == ("cell4", "", None)
    assert plain.expansion_ppm_per_k == 11.5  # steel when not stated
    # 5 K above 20 degC, 310.25 mm of steel legs: 17.8 um longer
    assert plain.leg_expansion_mm(25.0) == pytest.approx(11.5e-6 * 310.25 * 5)


@pytest.mark.parametrize(("text", "line", "words"), [
    (GEOMETRY + "serial = 17\n", 5, "serial must be text"),
    (GEOMETRY + "leg_expansion_ppm_per_k = -3\n", 5, "must be 0..1000"),
    (GEOMETRY + "[tolerances]\ndeviation_mm = 0\n", 6, "tolerances.deviation_mm must be "
     "positive"),
    (GEOMETRY + "[tolerances]\n\"dx_x+\" = 0.01\n", 6, "unknown key 'dx_x+'"),
    (GEOMETRY + "[tolerances]\ndecision_rule = \"lenient\"\n", 6, "must be one of guard-band"),
    # a drive's lead with its unit (tests/io/test_machine_screws.py)
    (GEOMETRY + "[screws.x]\nlead_mm = 5000\n", 6,
     "screws.x.lead_mm = 5000 mm is no drive's (screws advance 0.5 to 100 mm a revolution): "
     "micrometres written as mm?"),
    (GEOMETRY + "[screws.y]\nrevolution_mm = 0.01\n", 6, "is the unit mm?"),
    (GEOMETRY + "[screws.w]\nlead_mm = 5\n", 5, "axis 'w' is not one of x, y, z"),
    (GEOMETRY + "[screws.x]\npitch_mm = 5\n", 6, "unknown key 'pitch_mm'"),
])
def test_bad_machine_identity_refused_with_line(tmp_path, text, line, words):
    path = _write(tmp_path, "m.toml", text)
    with pytest.raises(InputError) as caught:
        read_machine(path)
    assert f"{path}:{line}:" in str(caught.value) and words in str(caught.value)


def test_campaign_identity_environment_override_and_rehearsed_date(tmp_path):
    _write(tmp_path, "machine.toml", IDENTIFIED)
    campaign = read_campaign(_write(tmp_path, "c.toml", CAMPAIGN))
    assert campaign.operator == "J. Martin"
    assert campaign.environment.ambient_c == 20.4 and campaign.environment.machine_c == 21.0
    assert campaign.override_expired.startswith("re-checked")
    assert campaign.simulator.ambient_c == 23.5
    assert campaign.campaign_date() == datetime.datetime(2026, 1, 10, 9, 0)
    (instrument,) = campaign.instruments(0.001)
    assert instrument == Instrument("y_x", "Mitutoyo", "543-790B", "12345678",
                                    "DKD-K-12345 2026-0412", datetime.date(2026, 3, 1),
                                    datetime.date(2027, 3, 1), 0.0015, 2.0, 0.001)
    assert instrument.standard_uncertainty_mm == pytest.approx(0.00075)
    assert instrument.expired(datetime.date(2027, 3, 1)) is False  # the due day holds
    assert instrument.expired(datetime.date(2027, 3, 2)) is True
    # the file the schema writes reads back as the same campaign
    again = read_campaign(_write(tmp_path, "again.toml", campaign_text(campaign)))
    assert again.gauges == campaign.gauges and again.operator == campaign.operator
    assert again.environment == campaign.environment
    assert again.override_expired == campaign.override_expired
    assert again.simulator == campaign.simulator


@pytest.mark.parametrize(("old", "new", "line", "words"), [
    ("due = 2027-03-01", "due = 2026-02-01", 20, "due 2026-02-01 is not after calibrated "
     "2026-03-01"),
    ("due = 2027-03-01", 'due = "2027-03-01"', 20, "must be a date (YYYY-MM-DD, not quoted)"),
    ("due = 2027-03-01", "due = 2027-03-01T10:00:00", 20, "must be a date"),
    ("uncertainty_mm = 0.0015", "uncertainty_mm = 0", 21, "must be positive"),
    ("uncertainty_mm = 0.0015", "uncertainty_mm = -0.001", 21, "must be positive"),
    ("uncertainty_k = 2.0", "uncertainty_k = 0.5", 22, "must be 1..10"),
    ('expired_gauges = "re-checked against gauge blocks on 2026-01-09"',
     'expired_gauges = "  "', 12, "needs a reason"),
    ("date = 2026-01-10T09:00:00", 'date = "yesterday"', 6, "must be a date and time"),
    ("ambient_c = 20.4", "ambient_c = 98.0", 9, "environment.ambient_c must be -40..80"),
    ("machine_c = 21.0", 'sensor = "thermometer"', 10, "must be one of controller"),
])
def test_bad_campaign_identity_refused_with_line(tmp_path, old, new, line, words):
    _write(tmp_path, "machine.toml", IDENTIFIED)
    assert old in CAMPAIGN
    path = _write(tmp_path, "c.toml", CAMPAIGN.replace(old, new))
    with pytest.raises(InputError) as caught:
        read_campaign(path)
    assert f"{path}:{line}:" in str(caught.value), str(caught.value)
    assert words in str(caught.value)


def test_a_gauge_without_its_link_is_refused_on_hardware(tmp_path):
    _write(tmp_path, "machine.toml", GEOMETRY)
    text = ('machine = "machine.toml"\n[controller]\nprofile = "cia402"\nport = "h:502"\n'
            + GAUGE)
    path = _write(tmp_path, "c.toml", text)
    with pytest.raises(InputError, match=r"c\.toml:5: gauge y_x needs 'protocol'"):
        read_campaign(path)


def test_a_temperature_sensor_needs_the_profiles_register(tmp_path):
    _write(tmp_path, "machine.toml", GEOMETRY)
    base = 'machine = "machine.toml"\n[simulator]\nprofile = "PROFILE"\n' \
           '[environment]\nsensor = "controller"\n'
    assert read_campaign(_write(tmp_path, "ok.toml", base.replace("PROFILE", "cia402"))
                         ).environment.sensor == "controller"
    path = _write(tmp_path, "c.toml", base.replace("PROFILE", "iai-pcon"))
    with pytest.raises(InputError, match=r"c\.toml:5: .*'iai-pcon' has no \[temperature\]"):
        read_campaign(path)
