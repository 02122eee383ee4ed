"""A smooth map searched beside the axis's encoder scale, which is then dropped as
redundant, takes the slope the scale held.

Found by ``bench/table_coverage.py`` on a bend of z alone (3.0 µm beyond its line,
45 µm/m of slope about the reference): the library's model held ``encoder_scale.z``,
so the map was searched without its slope ("detrended"); the backward step then
dropped the scale, and the slope went to neither. The table corrected none of it and
the map's band, certain of a slope it did not hold, left the error at -80 mm 11.7
times its standard uncertainty (3.5 µm against 0.30 µm)."""

from __future__ import annotations

import numpy as np

from ogacq.diagnose.diagnosis import diagnose
from ogacq.model.machine import MachineSpec
from ogacq.model.parameters import AXES, vector
from ogacq.protocol.plan import ProtocolConfig, planned_layout
from ogacq.protocol.scan_design import design_scan, sampled_band
from ogacq.sim.readings import simulated_readings
from ogacq.sim.truth import ScrewMap, SimTruth

MACHINE = MachineSpec(310.25, -100.0, 60.0, gauge_resolution_mm=0.0001)


def test_a_dropped_encoder_scale_leaves_its_slope_to_the_map():
    design = design_scan(MACHINE, ProtocolConfig(), noise_mm=0.0005)
    bend = ScrewMap((0.0, 0.0244719, 0.0172686))
    truth = SimTruth(vector({"joint_offset.x": 0.0358, "joint_offset.y": 0.4177,
                             "joint_offset.z": 0.4815}), 0.0005, {}, screw_map={2: bend})
    obs = simulated_readings(MACHINE, planned_layout(design.protocol, MACHINE), truth,
                             scatter_mm=0.0005, step_mm=MACHINE.gauge_resolution_mm, seed=10)
    d = diagnose(obs, pitch_band_mm=sampled_band(design.protocol, MACHINE))
    assert "encoder_scale.z" not in [e.name for e in d.effects]
    (m,) = [m for m in d.maps_over(dict.fromkeys(AXES, (-100.0, 60.0)),
                                   dict.fromkeys(AXES, 0.0)) if m.axis == "z"]
    (term,) = m.extra["terms"]
    assert term["shape"]["detrended"] == 0.0  # the slope is the map's
    q = np.array([-80.0, -60.0, -20.0, 20.0, 40.0])
    error = bend.error_mm(q) - bend.error_mm(np.zeros(1))[0]
    left = error - np.interp(q, m.positions_mm, m.forward_mm)
    u = np.interp(q, m.positions_mm, m.u_forward_mm)
    assert np.all(np.abs(left) <= 2 * u), (left / u).round(2)
