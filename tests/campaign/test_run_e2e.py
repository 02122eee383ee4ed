"""``ogacq run`` against the built-in simulator, through the real drivers.

The gauges' lines run at the simulator's speed (``line_at_speed``): these tests are of
what a campaign reads and concludes, the line's timing is tests/drivers' and
test_settle.py's."""

from pathlib import Path

import numpy as np
import pytest

from ogacq.session.records import GaugesSetRecord
from ogacq.session.store import load_session
from tests.campaign.conftest import write_campaign
from tests.cli.helpers import run_ogacq
from tests.recovery import recovered


@pytest.fixture(scope="module")
def ran(tmp_path_factory):
    """``ogacq run --json`` of a profile's campaign: its output and folder; each run once
    for the tests that read it."""
    done: dict[tuple[str, int], tuple[dict, Path]] = {}

    def run(profile: str, seed: int) -> tuple[dict, Path]:
        if (profile, seed) not in done:
            folder = tmp_path_factory.mktemp(profile)
            path = write_campaign(folder, seed=seed, profile=profile, line_at_speed=True)
            done[profile, seed] = (run_ogacq("run", path, "--json", check_json=True), folder)
        return done[profile, seed]
    return run


@pytest.mark.parametrize(("profile", "seed"), [("cia402", 3), ("iai-pcon", 8)])
def test_run_recovers_hidden_offsets_within_predicted_std(ran, profile, seed):
    out, campaign_dir = ran(profile, seed)
    hidden = out["hidden"]
    got = out["parameters"]["joint_offset"]
    std = out["std"]["joint_offset"]
    for axis in "xyz":
        truth = hidden[f"joint_offset.{axis}"]
        assert abs(truth) > 0.05  # there was something to find
        assert recovered(got[axis], truth, std[axis]), (axis, got[axis], truth, std[axis])
        assert std[axis] < 0.002
    # the end of the campaign, for a script: the verdict, the record's id, what next
    # (within the noise at 1e-6, not the verdict's 1 %: one run in a hundred says "NOT")
    assert out["verdict"]["verdict"] in ("consistent", "inconsistent")
    assert 1e-6 < out["verdict"]["p_value"] <= 1
    assert out["record_id"].startswith("OGQ-") and out["next"][0]["command"]
    session = load_session(campaign_dir / "session.jsonl")
    assert session.finished
    assert len(session.readings) == 72
    # the session names its station: protocol, ports and the software version
    assert session.header.software.startswith("ogacq ")
    assert session.header.station["controller"]["profile"] == profile
    assert len(session.header.station["gauges"]) == 6
    # every reading kept its raw frame and where it came from
    assert all(r.raw.startswith("01A") and r.source for r in session.readings)


def test_refit_reads_the_session_and_its_csv_export(ran, tmp_path):
    _, campaign_dir = ran("cia402", 3)
    session_path = campaign_dir / "session.jsonl"
    machine = campaign_dir / "machine.toml"
    from_session = run_ogacq("refit", session_path, "--machine", machine, "--json",
                             check_json=True)
    from ogacq.io.machine_file import read_machine
    from ogacq.session.convert import export_readings, import_readings

    csv_path = tmp_path / "readings.csv"
    assert export_readings(load_session(session_path), csv_path) == 72
    from_csv = run_ogacq("refit", csv_path, "--machine", machine, "--json", check_json=True)
    a = from_session["parameters"]["joint_offset"]
    b = from_csv["parameters"]["joint_offset"]
    std = from_session["std"]["joint_offset"]
    # the same readings; the CSV's columns (INTERCHANGE.md) do not carry how many gauge
    # values each reading averaged nor their scatter, from which the session derives
    # the display rounding its repeats share (identify/noise.py:_value_scatter): the
    # weights differ a little, the offsets by a few hundredths of their std (seen:
    # 15 nm of 660), never by what a calibration would notice
    assert all(abs(a[k] - b[k]) <= 0.1 * std[k] for k in "xyz"), (a, b, std)
    # and back: a session imported from the CSV holds the same readings as the CSV
    back = import_readings(csv_path, read_machine(machine), tmp_path / "imported.jsonl")
    again = run_ogacq("refit", back, "--machine", machine, "--json", check_json=True)
    c = again["parameters"]["joint_offset"]
    assert np.allclose([b[k] for k in "xyz"], [c[k] for k in "xyz"], atol=1e-6)


def test_six_gauges_on_one_multiplexer_port(campaign_dir):
    """A DMX/MUX box: six channels on one serial port, opened once and shared."""
    path = write_campaign(campaign_dir, seed=11, extra="", speed=50, line_at_speed=True)
    text = path.read_text().replace("[simulator]\n", '[simulator]\ngauge_layout = "multiplexer"\n')
    path.write_text(text)
    out = run_ogacq("run", path, "--json", check_json=True)
    for axis in "xyz":
        truth = out["hidden"][f"joint_offset.{axis}"]
        got = out["parameters"]["joint_offset"][axis]
        assert recovered(got, truth, out["std"]["joint_offset"][axis])
    session = load_session(campaign_dir / "session.jsonl")
    ports = {g["port"] for g in session.header.station["gauges"].values()}
    channels = {g["channel"] for g in session.header.station["gauges"].values()}
    assert len(ports) == 1 and channels == {"1", "2", "3", "4", "5", "6"}
    # each reading came from its own channel: byte 2 of the 01A frame
    for r in session.readings:
        expected = session.header.station["gauges"][r.gauge.key]["channel"]
        assert r.raw[1] == expected


def test_two_indicators_moved_from_leg_to_leg(campaign_dir):
    """The papers' station: two indicators, set on each leg in turn (here by the
    simulator's operator); each gauge of a leg is read through the indicator
    mounted there."""
    path = write_campaign(campaign_dir, seed=13, extra="", speed=50, line_at_speed=True)
    path.write_text(path.read_text().replace("[simulator]\n",
                                             '[simulator]\ngauge_layout = "moved"\n'))
    out = run_ogacq("run", path, "--json", check_json=True)
    for axis in "xyz":
        truth = out["hidden"][f"joint_offset.{axis}"]
        got = out["parameters"]["joint_offset"][axis]
        assert recovered(got, truth, out["std"]["joint_offset"][axis])
    session = load_session(campaign_dir / "session.jsonl")
    gauges = session.header.station["gauges"]
    assert len({g["port"] for g in gauges.values()}) == 2
    assert gauges["y_x"]["port"] == gauges["x_y"]["port"] == gauges["x_z"]["port"]
    assert [e.leg for e in session.of_type(GaugesSetRecord)] == ["x", "y", "z"]
    assert len(session.readings) == 72


# Seven protocols, six gauges: two stations, so that every protocol the drivers know
# reads a whole campaign, each gauge through its own wire format and driver. The simplex
# cable on one of them only: its every read is a 120 ms DTR pulse and three RFC 2217
# acknowledgements (pyserial polls for each every 50 ms): about 15 s of a campaign.
MIXED = {
    "cables": {"y_x": "usb-itn", "z_x": "usb-itn-keyboard", "x_y": "sylvac-simplex",
               "z_y": "uwave", "x_z": "digimatic", "y_z": "sylvac"},
    "with-01a": {"y_x": "usb-itn", "z_x": "usb-itn-keyboard", "x_y": "mitutoyo-01a",
                 "z_y": "uwave", "x_z": "digimatic", "y_z": "sylvac"},
}
# How each protocol's raw frame begins (a USB-ITN in data mode: an 01A reply over USB),
# and the port scheme of those not on a pseudo-terminal.
FRAME_BEGINS = {"mitutoyo-01a": ("01A",), "usb-itn": ("01A",), "uwave": ("DT1",),
                "digimatic": ("FFFF",), "sylvac": tuple("+- "), "sylvac-simplex": tuple("+- "),
                "usb-itn-keyboard": tuple("-0123456789")}
PORT_SCHEME = {"usb-itn": "usbsim://", "sylvac-simplex": "rfc2217://"}


@pytest.mark.parametrize("station", list(MIXED))
def test_one_gauge_of_each_protocol_end_to_end(campaign_dir, station):
    protocols = MIXED[station]
    path = write_campaign(campaign_dir, seed=4, line_at_speed=True)
    table = "\n".join(f'{key} = "{protocol}"' for key, protocol in protocols.items())
    path.write_text(path.read_text().replace(
        "[protocol]", f"[simulator.gauge_protocols]\n{table}\n\n[protocol]", 1))
    out = run_ogacq("run", path, "--json", check_json=True)
    for axis in "xyz":
        truth = out["hidden"][f"joint_offset.{axis}"]
        got, std = out["parameters"]["joint_offset"][axis], out["std"]["joint_offset"][axis]
        assert recovered(got, truth, std), (axis, got, truth, std)
    session = load_session(campaign_dir / "session.jsonl")
    assert session.finished and len(session.readings) == 72
    gauges = session.header.station["gauges"]
    assert {key: g["protocol"] for key, g in gauges.items()} == protocols
    raw = {r.gauge.key: r.raw for r in session.readings}
    for key, protocol in protocols.items():
        assert raw[key].startswith(FRAME_BEGINS[protocol]), (key, protocol, raw[key])
        if protocol in PORT_SCHEME:
            assert gauges[key]["port"].startswith(PORT_SCHEME[protocol]), gauges[key]
