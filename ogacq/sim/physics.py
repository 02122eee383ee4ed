"""What the gauges of a campaign see under a simulated truth, noise-free: the exact
model of the library's effects with the axes' own errors (``truth.py``) on top.

Errors along a joint's line move the joint as a changed ``q`` would (the error then
scales with ``1 + encoder_scale``, a change of parts in 1e-3 of a micrometre); a bowed
rail moves the joint centre across its line (``joint_sensitivity.predict_displaced``).
Each gauge stays where it was set, so its setting pose carries the errors of that
moment too: its joints' place, side and travel there (``JointHistory``).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from ogacq.model.error_maps import JointHistory
from ogacq.model.joint_sensitivity import predict_displaced
from ogacq.model.machine import MachineSpec
from ogacq.model.measurement import ReadingsLayout, predict_coordinates
from ogacq.sim.truth import SimTruth


def true_coordinates(truth: SimTruth, layout: ReadingsLayout, machine: MachineSpec,
                     history: JointHistory | None = None) -> np.ndarray:
    """(n,) what every reading of ``layout`` shows up to its gauge's zero, without noise.
    ``history``: each joint's side and travel since reversal at each reading (from the
    layout's recorded order when not given)."""
    if not truth.has_axis_errors:
        return predict_coordinates(truth.theta, layout, machine)
    history = history if history is not None else JointHistory.of(layout)
    moved = replace(
        layout,
        q_mm=truth.disturbed_q(layout.q_mm, history.side, history.travel_mm, layout.t_s),
        setting_q_mm=truth.disturbed_q(layout.setting_q_mm, history.setting_side,
                                       history.setting_travel_mm, 0.0))
    if not truth.rail_bow:
        return predict_coordinates(truth.theta, moved, machine)
    return predict_displaced(truth.theta, moved, machine, truth.across_mm(layout.q_mm, machine),
                             truth.across_mm(layout.setting_q_mm, machine))
