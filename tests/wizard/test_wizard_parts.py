"""The wizard's parts that need no terminal: expected ranges, the campaign file it
writes, its session header against ``run_campaign``'s, fault specs, the drawing."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from ogacq.campaign.campaign_file import (
    AxisEndpoint,
    Campaign,
    ControllerSpec,
    GaugeSpec,
    read_campaign,
)
from ogacq.campaign.guided import campaign_file_text, run_guided
from ogacq.campaign.run import run_campaign
from ogacq.cli.wizard.drawing import leg_drawing
from ogacq.cli.wizard.ui import parse_mm
from ogacq.io.machine_file import read_machine
from ogacq.model.expected_readings import ReadingExpectations, deviation_model, travel_needed_mm
from ogacq.model.machine import MachineSpec
from ogacq.protocol.plan import ProtocolConfig, reading_steps
from ogacq.protocol.runner import CampaignStopped
from ogacq.session.store import load_session
from ogacq.sim.faults import parse_fault
from tests.campaign.conftest import write_campaign

MACHINE = MachineSpec(leg_length_mm=310.25, rho_min_mm=-100.0, rho_max_mm=60.0,
                      gauge_resolution_mm=0.001)


def test_model_sensitivity_is_the_papers_linear_coefficients():
    # eq. 7: dy_x+ = (0.5 + sin a) tan a * drho_x + sin a * drho_y, a = asin(rho_max / L)
    a = math.asin(60.0 / 310.25)
    q_max = next(s.q_mm for s in reading_steps(ProtocolConfig(), MACHINE) if s.posture == "max")
    nominal, slope = deviation_model(MACHINE, "y_x", (0.0, 0.0, 0.0), q_max)
    assert nominal == pytest.approx(0.0, abs=1e-9)
    assert slope == pytest.approx([(0.5 + math.sin(a)) * math.tan(a), math.sin(a), 0.0],
                                  abs=1e-5)


def test_expected_range_from_setting_value_then_model_then_earlier_readings():
    steps = reading_steps(ProtocolConfig(cycles=2), MACHINE)
    zero, max_, min_ = (next(s for s in steps if s.leg == "x" and s.posture == p)
                        for p in ("zero", "max", "min"))
    exp = ReadingExpectations(MACHINE, max_offset_mm=2.0, repeat_tolerance_mm=0.05)
    assert exp.expected("y_x", zero.q_mm).basis.startswith("the gauge's range")
    exp.set_reference("y_x", zero.q_mm, 6.0)
    first = exp.expected("y_x", zero.q_mm)
    assert (first.low_mm, first.high_mm) == pytest.approx((5.95, 6.05))
    at_min = exp.expected("y_x", min_.q_mm)
    half = (at_min.high_mm - at_min.low_mm) / 2
    assert half == pytest.approx((0.0605 + 0.3223) * 2.0 + 0.05, abs=2e-3)
    assert at_min.contains(6.5) and not at_min.contains(7.0)
    exp.observe("y_x", zero.q_mm, 6.001)
    exp.observe("y_x", max_.q_mm, 6.412)
    again = exp.expected("y_x", max_.q_mm)  # a later cycle repeats the earlier reading
    assert again.basis.startswith("1 earlier reading")
    assert again.contains(6.45) and not again.contains(6.47)
    need = travel_needed_mm(MACHINE, "y_x", steps, 2.0)
    assert need == pytest.approx((0.0605 + 0.3223) * 2.0, abs=2e-3)


def test_typed_lengths_accept_decimal_comma_and_unit():
    assert parse_mm("5,71") == 5.71 and parse_mm(" -0.02 mm") == -0.02
    with pytest.raises(ValueError, match="type the value"):
        parse_mm("")
    with pytest.raises(ValueError, match="not a number"):
        parse_mm("five")


def test_fault_specs():
    plan = parse_fault("y_x:silence@10x3")
    assert (plan.gauge, plan.kind, plan.after_readings, plan.count) == ("y_x", "silence", 10, 3)
    assert parse_fault("z_y:unplug@0").count is None
    for bad in ("y_y:silence@1", "y_x:melt@1", "y_x silence"):
        with pytest.raises(ValueError):
            parse_fault(bad)


def test_drawing_fits_an_80_column_terminal_and_names_both_gauges():
    for leg, gauges in (("x", ("y_x", "z_x")), ("y", ("x_y", "z_y")), ("z", ("x_z", "y_z"))):
        text = leg_drawing(leg, 80)
        assert max(map(len, text.splitlines())) <= 80
        assert all(g in text for g in gauges) and f"{leg} leg" in text


@pytest.mark.parametrize("controller", [
    ControllerSpec("cia402", "192.168.0.10:502"),
    ControllerSpec("mr-je-c", "", axes={a: AxisEndpoint(f"192.168.3.1{k}:502", 255)
                                        for k, a in enumerate("xyz")}),
], ids=["shared", "per-axis"])
def test_campaign_file_for_hardware_reads_back_the_same(tmp_path: Path, controller):
    (tmp_path / "machine.toml").write_text("leg_length_mm = 310.25\nrho_min_mm = -100.0\n"
                                           "rho_max_mm = 60.0\ngauge_resolution_mm = 0.01\n")
    protocol = ProtocolConfig(cycles=2, settle_s=0.5)
    gauges = [GaugeSpec(g, "mitutoyo-01a", f"/dev/ttyUSB{k}")
              for k, g in enumerate(("y_x", "z_x", "x_y", "z_y", "x_z", "y_z"))]
    campaign = Campaign(tmp_path / "campaign.toml", read_machine(tmp_path / "machine.toml"),
                        tmp_path / "machine.toml", tmp_path / "session.jsonl", protocol,
                        controller, gauges)
    campaign.path.write_text(campaign_file_text(campaign, set(), None))
    again = read_campaign(campaign.path)
    assert again.protocol.to_dict() == protocol.to_dict()
    assert again.controller == campaign.controller
    assert [(g.gauge, g.port, g.protocol) for g in again.gauges] == \
        [(g.gauge, g.port, g.protocol) for g in gauges]
    assert again.session.resolve() == campaign.session.resolve()


def _stop_at_first_reading(progress) -> None:
    if progress.done:
        raise CampaignStopped("enough for a header")


@pytest.mark.slow
def test_session_header_matches_run_campaign(tmp_path: Path):
    """``run_guided`` runs through ``run_campaign``: the same header, plus the wizard's."""
    headers = []
    for name in ("plain", "guided"):
        campaign = read_campaign(write_campaign(tmp_path / name))
        kwargs = {"observer": _stop_at_first_reading}
        with pytest.raises(CampaignStopped):
            if name == "plain":
                run_campaign(campaign, **kwargs)
            else:
                run_guided(campaign, wrap=lambda works, device, writer: works,
                           set_gauges=lambda step: None, resume=None, wizard_header={},
                           rehearsal=None, **kwargs)
        headers.append(load_session(campaign.session).header.to_json())
    plain, guided = headers
    assert set(guided) - set(plain) == {"wizard"}
    assert set(plain) <= set(guided)
    for key in ("plan", "machine", "simulator"):
        assert guided[key] == plain[key]
    assert set(guided["station"]) == set(plain["station"])


def test_wizard_writes_and_test_reads_every_cable(tmp_path: Path):
    """The wizard's gauge test and its campaign file name the new cables like the others."""
    from ogacq.cli.wizard.connect import test_read
    from ogacq.sim.stack import make_gauge

    protocols = ("usb-itn", "usb-itn-keyboard", "sylvac-simplex", "uwave", "digimatic", "sylvac")
    keys = ("y_x", "z_x", "x_y", "z_y", "x_z", "y_z")
    endpoints = [make_gauge(p, lambda: 2.0004, resolution_mm=0.001, transport="pty",
                            name=f"sim {p}").start() for p in protocols]
    try:
        gauges = [GaugeSpec(k, p, e.port) for k, p, e in zip(keys, protocols, endpoints,
                                                              strict=True)]
        assert [test_read(g, timeout_s=2.0) for g in gauges] == [2.0] * 6
    finally:
        for endpoint in endpoints:
            endpoint.close()
    (tmp_path / "machine.toml").write_text("leg_length_mm = 310.25\nrho_min_mm = -100.0\n"
                                           "rho_max_mm = 60.0\ngauge_resolution_mm = 0.001\n")
    campaign = Campaign(tmp_path / "campaign.toml", read_machine(tmp_path / "machine.toml"),
                        tmp_path / "machine.toml", tmp_path / "session.jsonl",
                        ProtocolConfig(cycles=1), ControllerSpec("cia402", "10.0.0.2:502"), gauges)
    campaign.path.write_text(campaign_file_text(campaign, set(), None))
    assert [(g.gauge, g.protocol, g.port) for g in read_campaign(campaign.path).gauges] == \
        [(g.gauge, g.protocol, g.port) for g in gauges]


def test_log_lines_go_through_the_wizard_screen_while_it_runs():
    """A retry's warning printed straight to stderr would break into a live display."""
    import io
    import logging

    from rich.console import Console

    from ogacq.cli.repeated_warnings import OneLineFormatter, RepeatCollapsingHandler
    from ogacq.cli.wizard.ui import Screen, log_on_screen

    stderr, shown = io.StringIO(), io.StringIO()
    terminal = RepeatCollapsingHandler(stderr)
    terminal.setFormatter(OneLineFormatter())
    root = logging.getLogger()
    root.addHandler(terminal)
    log = logging.getLogger("ogacq_drivers.test")
    try:
        with log_on_screen(Screen(Console(file=shown, width=100))):
            for attempt in (1, 2, 3):
                log.warning("gauge z_x [x leg]: no reply, attempt %d of 3", attempt)
        log.warning("after the wizard")
    finally:
        root.removeHandler(terminal)
    assert "ogacq: warning: gauge z_x [x leg]: no reply, attempt 1 of 3" in shown.getvalue()
    assert "repeated 2 more times" in shown.getvalue()
    assert stderr.getvalue() == "ogacq: warning: after the wizard\n"


def test_the_wizard_makes_a_machine_file_from_questions(tmp_path, monkeypatch):
    """'new' at the machine-file question: the operator describes the machine (an
    impossible geometry is refused in words and asked again); the file written in
    the campaign's folder reads back as that machine."""
    import io

    from rich.console import Console

    from ogacq.cli.wizard.flow import WizardOptions, _Wizard
    from ogacq.cli.wizard.pause import InterruptGate
    from ogacq.cli.wizard.ui import Screen
    from ogacq.io.machine_file import read_machine

    answers = iter(["new",
                    "400", "50", "80", "0.001",  # Min above zero: refused
                    "400", "-120", "80", "abc", "0.001",  # a step that is not a number
                    "y"])
    monkeypatch.setattr("builtins.input", lambda prompt="": next(answers))
    shown = io.StringIO()
    wizard = _Wizard(Screen(Console(file=shown, width=100)), InterruptGate(), WizardOptions())
    machine, path = wizard._confirm_machine(None, None, tmp_path)
    assert path == tmp_path / "machine.toml" and read_machine(path) == machine
    assert (machine.leg_length_mm, machine.rho_min_mm, machine.rho_max_mm,
            machine.gauge_resolution_mm) == (400, -120, 80, 0.001)
    assert "rho_min_mm < 0 < rho_max_mm" in shown.getvalue()
    # in words, not Python's "could not convert string to float"
    assert "'abc' is not a number: type a length in mm" in shown.getvalue()
    assert "convert" not in shown.getvalue()


def test_a_choice_is_its_key_or_the_first_word_of_its_label(monkeypatch):
    """What a technician reads on the line is what they type: 'cia402', 'six', 'quit'
    choose as the numbers and letters do; a word two labels share chooses neither."""
    import io

    from rich.console import Console

    from ogacq.cli.wizard.ui import Option, Screen

    answers = iter(["CIA402", "six", "2", "Quit", "mitutoyo", "read", "m"])
    monkeypatch.setattr("builtins.input", lambda prompt="": next(answers))
    shown = io.StringIO()
    screen = Screen(Console(file=shown, width=100))
    profiles = [Option("1", "cia402"), Option("2", "iai-pcon")]
    assert screen.choose("Register map", profiles) == "1"
    indicators = [Option("6", "six, two per leg, left in place"), Option("2", "two, moved")]
    assert screen.choose("How many indicators?", indicators) == "6"
    assert screen.choose("How many indicators?", indicators) == "2"
    assert screen.choose("Resume or quit?", [Option("r", "resume"), Option("q", "quit")]) == "q"
    read = [Option("1", "mitutoyo-01a: Mitutoyo 01A ASCII"), Option("r", "read y_x by eye"),
            Option("m", "read z_x by eye")]
    assert screen.choose("How?", read) == "m"  # 'mitutoyo' and 'read' refused first
    assert shown.getvalue().count("type one of: 1, r, m") == 2


def test_a_terminal_closed_at_a_typed_reading_quits_the_campaign():
    """End of input while a dial's value is asked stops the campaign as a quit (the
    runner records it, the session stays resumable), never as an input error."""
    from ogacq.cli.wizard.guided_station import GuidedStation
    from ogacq.cli.wizard.pause import InterruptGate, OperatorQuit
    from ogacq.cli.wizard.ui import InputClosed
    from ogacq.protocol.plan import StabilityRule

    def closed(gauge, step):
        raise InputClosed("the terminal closed")

    step = reading_steps(ProtocolConfig(cycles=1), MACHINE)[0]
    station = GuidedStation(None, None, InterruptGate(),  # nothing read over a link
                            expectations=ReadingExpectations(MACHINE, max_offset_mm=2.0,
                                                             repeat_tolerance_mm=0.05),
                            by_eye={"y_x"}, ask_reading=closed, on_pause=lambda: None)
    with pytest.raises(OperatorQuit, match="the terminal closed"):
        list(station.read_gauges(step, ["y_x"], StabilityRule()))


def test_a_dial_read_by_eye_waits_after_a_move_and_not_where_nothing_moved():
    """The runner settles a step nothing moved before as well, so that gauges read by
    their values average as many values as at every other step; a person reading a
    dial then has nothing to wait for: the settle's fixed wait only follows a move."""
    from ogacq.cli.wizard.guided_station import GuidedStation
    from ogacq.cli.wizard.pause import InterruptGate
    from ogacq.protocol.plan import SettleRule

    class Inner:
        waited: list[float] = []

        def move(self, q_mm, timeout_s):
            return q_mm

        def settle(self, seconds):
            self.waited.append(seconds)

    inner = Inner()
    step = reading_steps(ProtocolConfig(cycles=1), MACHINE)[0]
    station = GuidedStation(inner, None, InterruptGate(),  # type: ignore[arg-type]
                            expectations=ReadingExpectations(MACHINE, max_offset_mm=2.0,
                                                             repeat_tolerance_mm=0.05),
                            by_eye={"y_x"}, ask_reading=None, on_pause=lambda: None)
    rule = SettleRule("stable", 1.5, 0.1)
    station.read_settled(step, ["y_x"], rule)  # the first reading: waited
    station.read_settled(step, ["y_x"], rule)  # read again, nothing moved
    station.move((0.0, 0.0, 0.0), 10.0)
    settled = station.read_settled(step, ["y_x"], rule)
    assert inner.waited == [1.5, 1.5] and settled["y_x"].value is None
