"""Bad campaign files are refused before anything moves, naming the line."""

import pytest

from tests.campaign.conftest import CONTROLLER, HEAD, MACHINE, gauge
from tests.cli.helpers import run_ogacq

ALL_GAUGES = "".join(gauge(k, "/dev/ttyUSB0", c) for c, k in
                     enumerate(("y_x", "z_x", "x_y", "z_y", "x_z", "y_z"), 1))


@pytest.mark.parametrize(("text", "line", "words"), [
    (HEAD + "colour = 3\n" + CONTROLLER + ALL_GAUGES, 3, "unknown key 'colour'"),
    (HEAD + CONTROLLER.replace('port = "127.0.0.1:1"\n', "") + ALL_GAUGES, 3, "needs 'port'"),
    (HEAD + CONTROLLER + ALL_GAUGES.replace('port = "/dev/ttyUSB0"\nchannel = 4\n',
                                            "channel = 4\n"), 21, "needs 'port'"),
    (HEAD + CONTROLLER + ALL_GAUGES + '[protocol]\npostures = ["zero", 80.0]\n', 37,
     "outside the workspace"),
    (HEAD + CONTROLLER + ALL_GAUGES.replace("channel = 2", "channel = 1"), 11,
     "gauges y_x (line 6) and z_x of the x leg both on port /dev/ttyUSB0 channel 1"),
    (HEAD + CONTROLLER + ALL_GAUGES.replace('port = "/dev/ttyUSB0"\nchannel = 2\n',
                                            'port = "/dev/ttyUSB0"\nchannel = 2\n'
                                            'uncertainty_mm = 1.5\n'), 16,
     "gauge z_x: uncertainty_mm = 1.5 mm is more than an indicator's certificate states "
     "(at most 0.1 mm): micrometres written as mm?"),
    (HEAD + CONTROLLER + ALL_GAUGES.replace('gauge = "y_z"', 'gauge = "z_z"'), 32,
     "gauges[5].gauge must be one of"),
    (HEAD + CONTROLLER + gauge("y_x", "/dev/ttyUSB0"), None, "no [[gauges]] entry for"),
    (HEAD + CONTROLLER + ALL_GAUGES + '[protocol]\napproach = "sideways"\n', 37, "approach"),
    (HEAD + CONTROLLER + ALL_GAUGES + '[protocol]\nsettle_s = -1\n', 37,
     "protocol.settle_s must be 0..3600, got -1"),
    (HEAD + CONTROLLER + ALL_GAUGES + '[stability]\ntimeout_s = nan\n', 37,
     "stability.timeout_s must be a finite number, got nan"),
    (HEAD + '[simulator]\nspeed = inf\n', 4, "simulator.speed must be a finite number"),
    # endpoints that cannot be: refused as the file's slip (exit 2), not "cannot connect"
    (HEAD + CONTROLLER.replace("127.0.0.1:1", "127.0.0.1:99999") + ALL_GAUGES, 5,
     "port '127.0.0.1:99999': TCP port 99999 is beyond 65535 (Modbus TCP's is 502)"),
    (HEAD + CONTROLLER.replace("127.0.0.1:1", "192.168.0.10") + ALL_GAUGES, 5,
     "port '192.168.0.10' is an IP address without its port: Modbus TCP is host:port "
     "(192.168.0.10:502 for Modbus's own port)"),
    # real or simulated, said once: the real ports were silently ignored before
    (HEAD + CONTROLLER + '[simulator]\nseed = 1\n', 6,
     "a [simulator] table and real ports ([controller] 127.0.0.1:1)"),
    (HEAD + '[simulator]\nseed = 1\n' + gauge("y_x", "/dev/ttyUSB0"), 3,
     "a [simulator] table and real ports (gauge y_x on /dev/ttyUSB0)"),
])
def test_bad_campaign_refused_with_line(tmp_path, text, line, words):
    (tmp_path / "machine.toml").write_text(MACHINE)
    path = tmp_path / "campaign.toml"
    path.write_text(text)
    proc = run_ogacq("run", path)
    assert proc.returncode == 2, proc.stdout + proc.stderr
    message = proc.stderr.strip()
    assert len(message.splitlines()) == 1 and "Traceback" not in proc.stderr, message
    assert words in message
    if line is not None:
        assert f"{path}:{line}:" in message
    # refused before anything was opened, moved or recorded
    assert not (tmp_path / "s.jsonl").exists()


@pytest.mark.parametrize(("protocol", "first", "second", "said"), [
    # 01A: a gauge with no channel is asked channel 1 (the driver's default)
    ("mitutoyo-01a", None, "1", "(channel not set and 1 read the same mitutoyo-01a indicator)"),
    # U-WAVE: "01" takes channel 01 of any group, group 00's "0001" among them
    ("uwave", '"0001"', '"01"', "(channel 0001 and 01 read the same uwave indicator)"),
])
def test_one_indicator_spelled_two_ways_refused(tmp_path, protocol, first, second, said):
    """The two gauges of a leg on one port are told apart by what the driver asks
    for, not by how the channel is written."""
    gauges = ""
    for c, key in enumerate(("y_x", "z_x", "x_y", "z_y", "x_z", "y_z"), 1):
        channel = {1: first, 2: second}.get(c, f'"000{c}"' if protocol == "uwave" else str(c))
        gauges += (f'[[gauges]]\ngauge = "{key}"\nprotocol = "{protocol}"\n'
                   f'port = "/dev/ttyUSB0"\n' + (f"channel = {channel}\n" if channel else ""))
    (tmp_path / "machine.toml").write_text(MACHINE)
    path = tmp_path / "campaign.toml"
    path.write_text(HEAD + CONTROLLER + gauges)
    proc = run_ogacq("run", path)
    assert proc.returncode == 2, proc.stdout + proc.stderr
    assert "gauges y_x (line 6) and z_x of the x leg both on port /dev/ttyUSB0" in proc.stderr
    assert said in proc.stderr


def test_two_protocols_on_one_port_refused(tmp_path):
    (tmp_path / "machine.toml").write_text(MACHINE)
    path = tmp_path / "campaign.toml"
    mixed = ALL_GAUGES.replace('gauge = "z_x"\nprotocol = "mitutoyo-01a"',
                               'gauge = "z_x"\nprotocol = "sylvac"')
    path.write_text(HEAD + CONTROLLER + mixed)
    proc = run_ogacq("run", path)
    assert proc.returncode == 2
    assert f"{path}:11:" in proc.stderr and "one port speaks one protocol" in proc.stderr


def test_unreachable_controller_is_named_and_nothing_is_written(tmp_path):
    (tmp_path / "machine.toml").write_text(MACHINE)
    path = tmp_path / "campaign.toml"
    path.write_text(HEAD + CONTROLLER + ALL_GAUGES)  # nothing listens on 127.0.0.1:1
    proc = run_ogacq("run", path)
    assert proc.returncode == 3
    message = proc.stderr.strip()
    assert len(message.splitlines()) == 1 and "Traceback" not in proc.stderr, message
    assert "127.0.0.1:1" in message and "cannot connect" in message
    assert not (tmp_path / "s.jsonl").exists()


def test_one_indicator_may_serve_one_gauge_per_leg(tmp_path):
    """The papers' two indicators, moved leg to leg: accepted, and known as moved."""
    from ogacq.campaign.campaign_file import read_campaign

    (tmp_path / "machine.toml").write_text(MACHINE)
    path = tmp_path / "campaign.toml"
    path.write_text(HEAD + CONTROLLER + "".join(
        gauge(key, "/dev/ttyUSB0" if key in ("y_x", "x_y", "x_z") else "/dev/ttyUSB1")
        for key in ("y_x", "z_x", "x_y", "z_y", "x_z", "y_z")))
    assert read_campaign(path).moved_indicators == {
        "/dev/ttyUSB0": ["y_x", "x_y", "x_z"], "/dev/ttyUSB1": ["z_x", "z_y", "y_z"]}


NEW_CABLES = {"y_x": ("usb-itn", "usb"), "z_x": ("usb-itn-keyboard", "keyboard"),
              "x_y": ("sylvac-simplex", "/dev/ttyUSB1"), "z_y": ("uwave", "/dev/ttyUSB2"),
              "x_z": ("digimatic", "/dev/ttyUSB3"), "y_z": ("usb-itn", "usb:B4562")}


def test_every_cable_is_named_like_the_others(tmp_path):
    from ogacq.campaign.campaign_file import read_campaign

    (tmp_path / "machine.toml").write_text(MACHINE)
    path = tmp_path / "campaign.toml"
    entries = "".join(f'[[gauges]]\ngauge = "{key}"\nprotocol = "{protocol}"\nport = "{port}"\n'
                      for key, (protocol, port) in NEW_CABLES.items())
    path.write_text(HEAD + CONTROLLER + entries)
    campaign = read_campaign(path)
    assert {g.gauge: (g.protocol, g.port) for g in campaign.gauges} == NEW_CABLES


@pytest.mark.parametrize(("table", "words"), [
    ('gauge_protocols = { z_q = "usb-itn" }', "'z_q' is not one of"),
    ('gauge_protocols = { z_y = "usb-itm" }', "gauge_protocols.z_y must be one of"),
    ('gauge_protocol = "rs232"', "simulator.gauge_protocol must be one of"),
    ('gauge_layout = "multiplexer"\ngauge_protocol = "usb-itn"', "01A box"),
])
def test_bad_simulated_protocols_are_refused_with_line(tmp_path, table, words):
    from ogacq.campaign.campaign_file import read_campaign
    from ogacq.io.errors import InputError

    (tmp_path / "machine.toml").write_text(MACHINE)
    path = tmp_path / "campaign.toml"
    path.write_text(HEAD + f"[simulator]\nseed = 1\n{table}\n")
    with pytest.raises(InputError) as error:
        read_campaign(path)
    assert words in str(error.value) and f"{path}:" in str(error.value)


def test_simulated_protocols_go_into_the_session_header_for_a_resume(tmp_path):
    from ogacq.campaign.campaign_file import SimulatorSpec, read_campaign

    (tmp_path / "machine.toml").write_text(MACHINE)
    path = tmp_path / "campaign.toml"
    path.write_text(HEAD + '[simulator]\ngauge_protocol = "uwave"\n'
                    'gauge_protocols = { z_y = "usb-itn-keyboard", x_y = "usb-itn" }\n')
    spec = read_campaign(path).simulator
    assert spec is not None and spec.gauge_protocol == "uwave"
    assert SimulatorSpec.from_header(spec.header()) == spec


def test_endpoint_per_axis_and_unit_ids(tmp_path):
    from ogacq.campaign.campaign_file import read_campaign

    (tmp_path / "machine.toml").write_text(MACHINE)
    path = tmp_path / "campaign.toml"
    per_axis = ('[controller]\nprofile = "cia402"\n[controller.axes]\n'
                'x = { port = "10.0.0.11:502", device_id = 255 }\n'
                'y = { port = "10.0.0.12:502" }\nz = { port = "10.0.0.13:502", device_id = 0 }\n')
    path.write_text(HEAD + per_axis + ALL_GAUGES)
    c = read_campaign(path).controller
    assert [c.port_of(a) for a in "xyz"] == ["10.0.0.11:502", "10.0.0.12:502", "10.0.0.13:502"]
    assert c.device_ids() == {"x": 255, "z": 0}
    # the shared form still works, with a per-axis unit id beside it
    path.write_text(HEAD + CONTROLLER + '[controller.axes]\ny = { device_id = 7 }\n' + ALL_GAUGES)
    c = read_campaign(path).controller
    assert [c.port_of(a) for a in "xyz"] == ["127.0.0.1:1"] * 3 and c.device_ids() == {"y": 7}


@pytest.mark.parametrize(("axes", "words"), [
    ('x = { port = "10.0.0.11:502" }\n', "needs 'port', or a port for each of x, y and z"),
    ('w = { port = "10.0.0.11:502" }\n', "axis 'w' is not one of x, y, z"),
    ('x = { port = "a:1", device_id = 300 }\n', "device_id must be 0..255"),
    ('x = { port = "a:1", unit = 3 }\n', "unknown key 'unit'"),
    ('x = { port = "/dev/ttyUSB0", device_id = 255 }\ny = { port = "a:1" }\n'
     'z = { port = "a:2" }\n', "device id 255 cannot be addressed over Modbus RTU"),
])
def test_bad_axis_endpoints_refused(tmp_path, axes, words):
    from ogacq.campaign.campaign_file import read_campaign
    from ogacq.io.errors import InputError

    (tmp_path / "machine.toml").write_text(MACHINE)
    path = tmp_path / "campaign.toml"
    path.write_text(HEAD + '[controller]\nprofile = "cia402"\n[controller.axes]\n' + axes
                    + ALL_GAUGES)
    with pytest.raises(InputError, match=words):
        read_campaign(path)


def test_a_rehearsal_asks_for_its_gauge_lines_at_its_speed(tmp_path):
    """`[simulator] line_at_speed = true`: each gauge's serial line runs `speed` times
    faster than its baud rate (the same frames on the same pty, each byte's time
    divided); a resumed session's header asks for it again. Without it, the real line."""
    from ogacq.campaign.campaign_file import SimulatorSpec, read_campaign
    from ogacq.campaign.station import start_simulator
    from tests.campaign.conftest import write_campaign

    for line_at_speed, divided_by in ((True, 50.0), (False, 1.0)):
        extra = "line_at_speed = true\n" if line_at_speed else ""
        path = write_campaign(tmp_path / str(line_at_speed), speed=50)
        path.write_text(path.read_text().replace("[protocol]", extra + "[protocol]"))
        campaign = read_campaign(path)
        assert campaign.simulator is not None
        assert campaign.simulator.line_at_speed is line_at_speed
        header = campaign.simulator.header()
        assert ("line_at_speed" in header) is line_at_speed  # unchanged when not asked
        assert SimulatorSpec.from_header(header) == campaign.simulator
        stack = start_simulator(campaign.machine, campaign.simulator)
        try:
            for gauge in stack.gauges.values():
                line = gauge.settings.byte_time_s  # type: ignore[attr-defined]
                paced = gauge.byte_time_s  # type: ignore[attr-defined]
                assert paced == pytest.approx(line / divided_by)
        finally:
            stack.close()
