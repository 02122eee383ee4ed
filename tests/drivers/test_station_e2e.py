"""Real drivers against the simulator: home, move to the papers' postures, read the
gauges, and see the readings the simulated geometry implies."""

import numpy as np
import pytest

from ogacq_drivers.axes.controller import AxisController
from ogacq_drivers.axes.modbus_link import ModbusLink
from ogacq_drivers.axes.profile import load_profile
from ogacq_drivers.indicators import open_indicator, read_stable
from ogacq.model.gauges import Gauge
from ogacq.model.machine import MachineSpec
from ogacq.model.measurement import ReadingsLayout, predict_coordinates
from ogacq.model.parameters import AXES, vector
from ogacq.protocol.plan import ProtocolConfig, reading_steps
from ogacq.sim.stack import SimulatorConfig, SimulatorStack
from ogacq.sim.truth import SimTruth

MACHINE = MachineSpec(310.25, -100.0, 60.0, gauge_resolution_mm=0.001)
REPLY_TIMEOUT_S = 5.0
TRUTH = {"joint_offset.x": 0.8, "joint_offset.y": -1.1, "joint_offset.z": 0.5,
         "leg_length.z": 0.3, "squareness.xy": 0.4}


@pytest.mark.parametrize("profile", ["cia402", "iai-pcon"])
def test_papers_postures_read_what_the_geometry_implies(profile):
    truth = SimTruth(vector(TRUTH), noise_mm=0.0)
    with SimulatorStack(SimulatorConfig(MACHINE, truth, profile=profile, speed=50)) as sim:
        info = sim.info()["modbus"]
        prof = load_profile(profile)
        # the profile's 0.2 s is a real drive's answer time; this simulator shares a
        # busy CI's two cores with the suite, so a reply is waited for as long as a
        # hang takes to show, not as long as a drive's (issue 36.8)
        if info["transport"] == "tcp":
            link = ModbusLink.for_profile(prof, host=info["host"], port=info["port"],
                                          timeout_s=REPLY_TIMEOUT_S)
        else:
            link = ModbusLink.for_profile(prof, serial_port=info["port"],
                                          timeout_s=REPLY_TIMEOUT_S)
        with link.connect():
            controller = AxisController(prof, link)
            controller.enable()
            controller.home()
            gauges = {key: open_indicator(g.protocol, g.port, unit="mm", where=key)
                      for key, g in sim.gauges.items()}
            try:
                zero_reading = {}
                deviations = []
                plan = ProtocolConfig(postures=("zero", "max", "min"), cycles=1)
                readings = [(s, key) for s in reading_steps(plan, MACHINE) for key in s.gauges]
                for step, key in readings:
                    planned = Gauge.parse(key)
                    target = dict(zip(AXES, step.q_mm, strict=True))
                    controller.move_to(target, timeout_s=20)
                    q = np.array([controller.resolved_targets_mm(target)[a] for a in AXES])
                    value = read_stable(gauges[key], 2, 0.0015, 5.0).value_mm
                    if step.posture == "zero":
                        zero_reading[key] = value
                        continue
                    # the deviation from Zero that the hidden geometry implies
                    layout = ReadingsLayout.build(
                        [np.zeros(3), q], [planned.indices[1]] * 2, [planned.indices[0]] * 2,
                        approach=np.zeros((2, 3), dtype=int))
                    expected = np.diff(predict_coordinates(vector(TRUTH), layout, MACHINE))[0]
                    measured = value - zero_reading[key]
                    deviations.append(expected)
                    assert measured == pytest.approx(expected, abs=0.0015), (key, step.posture)
                assert len(deviations) == 12
                assert max(map(abs, deviations)) > 0.1  # the hidden geometry shows
            finally:
                for g in gauges.values():
                    g.close()
