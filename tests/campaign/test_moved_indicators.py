"""Two indicators moved from leg to leg (the papers' station) under `ogacq run`.

The operator is real here: `ogacq run` runs in a pseudo-terminal against a
simulator started by the test, which plays the technician: when the prompt
names a leg, it moves the simulated indicators there and presses Enter.
"""

from __future__ import annotations

import os
import re
import sys

import pexpect
import pytest

from ogacq.io.machine_file import read_machine
from ogacq.session.store import load_session
from ogacq.sim.stack import SimulatorConfig, SimulatorStack
from ogacq.sim.truth import random_truth
from tests.campaign.conftest import HEAD, MACHINE, gauge
from tests.cli.helpers import run_ogacq
from tests.recovery import recovered

ANSI = re.compile(r"\x1b\[[0-9;?]*[A-Za-z]")


def _campaign_text(stack: SimulatorStack) -> str:
    info = stack.info()
    m = info["modbus"]
    text = (HEAD + f'[controller]\nprofile = "{m["profile"]}"\nport = "{m["host"]}:{m["port"]}"\n'
            '[protocol]\nsettle_s = 0.01\n')
    return text + "".join(gauge(key, g["port"]) for key, g in info["gauges"].items())


@pytest.fixture
def moved_station(tmp_path):
    (tmp_path / "machine.toml").write_text(MACHINE)
    stack = SimulatorStack(SimulatorConfig(read_machine(tmp_path / "machine.toml"),
                                           random_truth(21), speed=50, seed=21,
                                           gauge_layout="moved"))
    with stack:
        path = tmp_path / "campaign.toml"
        path.write_text(_campaign_text(stack))
        yield stack, path


def test_the_operator_is_asked_at_each_leg_and_the_offsets_come_out(moved_station):
    stack, path = moved_station
    env = {**os.environ, "TERM": "xterm-256color", "COLUMNS": "120"}
    child = pexpect.spawn(sys.executable, ["-m", "ogacq", "run", str(path), "--json"],
                          env=env, encoding="utf-8", timeout=60, dimensions=(50, 120))
    try:
        prompts = []
        for leg in "xyz":
            child.expect(rf"set the gauges on the {leg} leg")
            child.expect(r"Press Enter when both are set")
            prompts.append(ANSI.sub("", child.before))
            stack.set_gauges(leg)  # the technician moves the two indicators
            child.sendline("")
        child.expect(pexpect.EOF, timeout=60)
        output = ANSI.sub("", child.before)
    finally:
        child.close(force=True)
    assert child.exitstatus == 0, output
    ports = {key: g["port"] for key, g in stack.info()["gauges"].items()}
    assert f"along y: the indicator on {ports['y_x']}" in prompts[0]
    assert f"along z: the indicator on {ports['z_y']}" in prompts[1]
    result = load_session(path.parent / "s.jsonl")
    assert result.finished and len(result.readings) == 72
    hidden = stack.machine.truth.hidden()
    fit = result.result.refit
    for axis in "xyz":
        assert recovered(fit["parameters"]["joint_offset"][axis],
                         hidden[f"joint_offset.{axis}"], fit["std"]["joint_offset"][axis])


def test_without_a_terminal_it_is_refused_before_anything_opens(moved_station):
    _, path = moved_station
    proc = run_ogacq("run", path)
    assert proc.returncode == 2, proc.stdout + proc.stderr
    message = proc.stderr.strip()
    assert len(message.splitlines()) == 1 and "Traceback" not in message
    assert "needs an operator at each leg" in message and str(path) in message
    assert not (path.parent / "s.jsonl").exists()
