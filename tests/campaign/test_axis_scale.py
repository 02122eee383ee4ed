"""An axis scale: declared in the campaign file (bad tables refused naming the line),
served by the simulator on its own line and read through the real gauge codec, and the
ISO 230-2 positioning test it makes, which recovers a screw's cyclic error along the
whole travel."""

from __future__ import annotations

import dataclasses
import json
import time

import numpy as np
import pytest

from ogacq.campaign.campaign_file import read_campaign, scale_name
from ogacq.campaign.positioning import run_positioning, session_result
from ogacq.campaign.station import open_gauges, simulator_scales, start_simulator
from ogacq.cli.app import main
from ogacq.errors import InputError, Refused, StorageError
from ogacq.model.parameters import PARAM_INDEX
from ogacq.protocol.positioning import positioning_plan
from ogacq.protocol.runner import CampaignStopped
from ogacq.session.records import EndRecord, MoveRecord, PositionRecord
from ogacq.session.store import load_session
from tests.campaign.conftest import CONTROLLER, HEAD, MACHINE, gauge, write_campaign

ALL_GAUGES = "".join(gauge(k, f"/dev/ttyUSB{n}") for n, k in
                     enumerate(("y_x", "z_x", "x_y", "z_y", "x_z", "y_z")))
SCALE = '[axis_scale.x]\nprotocol = "mitutoyo-01a"\nport = "/dev/ttyUSB7"\n'
LEAD = "[lead_screw.x]\namplitude_mm = 0.004\npitch_mm = 5.0\nphase_deg = 30.0\n"


@pytest.mark.parametrize(("text", "line", "words"), [
    (HEAD + CONTROLLER + ALL_GAUGES + SCALE.replace("[axis_scale.x]", "[axis_scale.w]"), 30,
     "axis 'w' is not one of x, y, z"),
    (HEAD + CONTROLLER + ALL_GAUGES + SCALE + "stroke_mm = 100\n", 33, "unknown key 'stroke_mm'"),
    (HEAD + CONTROLLER + ALL_GAUGES + SCALE.replace('port = "/dev/ttyUSB7"\n', ""), 30,
     "the x axis scale needs 'port'"),
    (HEAD + CONTROLLER + ALL_GAUGES + SCALE.replace("USB7", "USB2"), 32,
     "the x axis scale is on /dev/ttyUSB2 as gauge x_y is"),
    (HEAD + CONTROLLER + ALL_GAUGES + SCALE + "resolution_mm = 0.0001\n", 33,
     "axis_scale.x.resolution_mm must be 0.001..0.1"),
    (HEAD + '[simulator]\nseed = 1\n' + SCALE, 3,
     "a [simulator] table and real ports (x axis scale on /dev/ttyUSB7)"),
])
def test_a_bad_axis_scale_is_refused_naming_its_line(tmp_path, text, line, words):
    (tmp_path / "machine.toml").write_text(MACHINE)
    path = tmp_path / "campaign.toml"
    path.write_text(text)
    with pytest.raises(InputError) as refused:
        read_campaign(path)
    assert words in refused.value.problem and refused.value.line == line, str(refused.value)


def test_a_station_scale_reads_back_as_written(tmp_path):
    (tmp_path / "machine.toml").write_text(MACHINE)
    path = tmp_path / "campaign.toml"
    path.write_text(HEAD + CONTROLLER + ALL_GAUGES + SCALE + 'serial = "AT715-0042"\n')
    scale = read_campaign(path).axis_scales["x"]
    assert (scale.protocol, scale.port, scale.serial, scale.resolution_mm) == \
        ("mitutoyo-01a", "/dev/ttyUSB7", "AT715-0042", 0.001)
    from ogacq.campaign.campaign_file import campaign_text

    path.write_text(campaign_text(read_campaign(path)))
    assert read_campaign(path).axis_scales == {"x": scale}


def test_the_simulated_scale_reads_the_joint_through_the_real_codec(tmp_path):
    """The scale's frames on its own pseudo-terminal, decoded by the 01A driver, follow
    the simulated joint (its lead screw's error included) to the display step."""
    (tmp_path / "effects.toml").write_text(LEAD)
    campaign = read_campaign(write_campaign(tmp_path, speed=100, extra="[axis_scale.x]\n"))
    simulator = dataclasses.replace(campaign.simulator, effects=tmp_path / "effects.toml")
    with start_simulator(campaign.machine, simulator) as stack:
        specs = simulator_scales(stack)
        assert specs["x"].port.startswith("/dev/") and specs["x"].port != \
            stack.gauges["y_x"].port  # a pty of its own, as each leg gauge's
        with open_gauges([specs["x"].as_gauge("x")]) as indicators:
            stack.motion.set_servo("x", True)
            for q in (-37.31, 12.6):
                stack.motion.move_to("x", q)
                deadline = time.monotonic() + 10.0
                while stack.motion.snapshot("x").moving and time.monotonic() < deadline:
                    time.sleep(0.01)
                reading = indicators[scale_name("x")].read(timeout_s=5.0)
                assert reading.frame.startswith(b"01A")
                truth = stack.machine.joint_mm(0)
                raw = stack.motion.raw_position_mm("x")
                screw = 0.004 * np.sin(2 * np.pi * raw / 5.0 + np.radians(30.0))
                offset = stack.machine.truth.theta[PARAM_INDEX["joint_offset.x"]]
                assert abs(raw - q) < 1e-6 and abs(truth - (raw + screw + offset)) < 1e-9
                # the display step and five times the scale's noise
                assert abs(reading.value_mm - truth) <= 0.0005 + 5 * 0.0003


def test_the_positioning_test_recovers_a_cyclic_screw_error(tmp_path):
    """ISO 230-2 targets at irregular intervals, two runs each way against the simulated
    machine: the deviations at each target are the screw's error within the scale's
    noise, and its amplitude comes back within 10 %."""
    campaign_path = write_campaign(tmp_path, speed=200, extra="[axis_scale.x]\n")
    (tmp_path / "effects.toml").write_text("[joint_offset]\nx = 0.4\n" + LEAD)
    text = campaign_path.read_text().replace("[simulator]\n",
                                             '[simulator]\neffects = "effects.toml"\n'
                                             "line_at_speed = true\n")
    campaign_path.write_text(text)
    campaign = read_campaign(campaign_path)
    plan = positioning_plan(campaign.machine, "x", runs=2, drive_step_mm=0.01)
    assert len(plan.targets_mm) >= 5 and len(set(np.round(np.diff(plan.targets_mm), 2))) > 5
    session = run_positioning(campaign, plan, tmp_path / "positioning.jsonl")
    assert len(session.of_type(PositionRecord)) == plan.readings
    result = session_result(session)
    truth = 0.004 * np.sin(2 * np.pi * result.targets_mm / 5.0 + np.radians(30.0))
    truth -= truth.mean()
    # the mean of four readings, each averaging the scale's 0.3 µm noise over its settle
    assert np.max(np.abs(result.mean_mm - truth)) < 0.0006
    design = np.column_stack([np.sin(2 * np.pi * result.targets_mm / 5.0),
                              np.cos(2 * np.pi * result.targets_mm / 5.0),
                              np.ones_like(result.targets_mm)])
    a, b, _ = np.linalg.lstsq(design, result.mean_mm, rcond=None)[0]
    assert abs(np.hypot(a, b) - 0.004) < 0.0004
    assert 0.008 - 0.0015 < result.figures.E < 0.008 + 0.0015


def test_a_positioning_test_stopped_half_way_continues_and_writes_its_figures(tmp_path,
                                                                              capsys):
    """Interrupted after 20 readings (recorded, the axes stopped), the same command
    continues it: every target read once per run and direction, the first one left
    approached from its run's own start, and the figures printed and written as JSON."""
    campaign_path, plan, session = stopped_y_test(tmp_path, 20, KeyboardInterrupt())
    assert len(load_session(session).of_type(PositionRecord)) == 20
    assert main(["positioning", str(campaign_path), "--axis", "y", "--runs", "2", "--json"]) == 0
    printed = json.loads(capsys.readouterr().out.splitlines()[-1])
    done = load_session(session)
    keys = [(r.run, r.direction, r.target_mm) for r in done.of_type(PositionRecord)]
    assert len(keys) == len(set(keys)) == plan.readings and done.finished
    first_left = plan_steps_read(plan)[20]
    moves = [m for m in done.of_type(MoveRecord)]
    resumed = next(k for k, m in enumerate(moves) if m.purpose == "overrun" and k > 20)
    assert moves[resumed].q_mm[1] == pytest.approx(min(plan.targets_mm) - plan.overrun_mm
                                                   if first_left.direction > 0 else
                                                   max(plan.targets_mm) + plan.overrun_mm)
    written = json.loads(session.with_suffix(".json").read_text())
    assert written == printed and written["iso230_2"]["standard"] == "ISO 230-2:2014, clause 3"
    assert written["drive_step_mm"] == 0.01 and len(written["targets_mm"]) == len(plan.targets_mm)


@pytest.mark.parametrize(("raised", "status"), [
    (StorageError("positioning-y.jsonl", OSError(28, "No space left on device")), "stopped"),
    (CampaignStopped("deadline: the campaign's time is up", "deadline"), "deadline")])
def test_a_positioning_test_stopped_by_the_disk_or_a_deadline_stops_the_axes(
        tmp_path, raised, status):
    """A full disk (or a stop of its own kind) mid-test ends as a campaign's does: the
    axes stopped, the end recorded with its own status, CampaignStopped raised."""
    _, _, session = stopped_y_test(tmp_path, 5, raised)
    (end,) = load_session(session).of_type(EndRecord)
    assert (end.status, end.axes_stopped, end.readings) == (status, True, 5)


def stopped_y_test(tmp_path, after: int, raised: BaseException):
    """A two-run positioning test of y on the simulator, ``raised`` out of its progress
    after ``after`` readings (CampaignStopped the outcome): its campaign file, plan and
    session."""
    campaign_path = write_campaign(tmp_path, speed=200, extra="[axis_scale.y]\n")
    campaign_path.write_text(campaign_path.read_text().replace(
        "[simulator]\n", "[simulator]\nline_at_speed = true\n"))
    campaign = read_campaign(campaign_path)
    plan = positioning_plan(campaign.machine, "y", runs=2, drive_step_mm=0.01)
    session = tmp_path / "positioning-y.jsonl"

    def stop(progress):
        if progress.done == after:
            raise raised

    with pytest.raises(CampaignStopped):
        run_positioning(campaign, plan, session, observer=stop)
    return campaign_path, plan, session


def plan_steps_read(plan):
    return [s for s in plan.steps() if s.read]


def test_a_scale_past_its_certificate_is_refused_before_anything_moves(tmp_path):
    campaign_path = write_campaign(tmp_path, extra='[axis_scale.x]\nserial = "AT-1"\n'
                                   "calibrated = 2024-01-10\ndue = 2025-01-10\n")
    campaign = read_campaign(campaign_path)
    plan = positioning_plan(campaign.machine, "x", runs=2, drive_step_mm=0.01)
    with pytest.raises(Refused, match="gauge scale_x .*AT-1.* past the due date"):
        run_positioning(campaign, plan, tmp_path / "positioning.jsonl")
    assert not (tmp_path / "positioning.jsonl").exists()


@pytest.mark.parametrize(("simulated", "words"), [
    (True, "add an [axis_scale.z] table (an empty one: the simulator serves it)"),
    (False, "add an [axis_scale.z] table (its protocol and port)")])
def test_an_axis_without_a_scale_is_refused_saying_what_to_add(tmp_path, capsys, simulated,
                                                               words):
    (tmp_path / "machine.toml").write_text(MACHINE)
    path = write_campaign(tmp_path, extra="[axis_scale.y]\n") if simulated else \
        tmp_path / "campaign.toml"
    if not simulated:
        path.write_text(HEAD + CONTROLLER + ALL_GAUGES + SCALE)
    assert main(["positioning", str(path), "--axis", "z"]) == 2
    assert words in " ".join(capsys.readouterr().err.split())
