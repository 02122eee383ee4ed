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
from ogacq.model.parameters import PARAM_INDEX
from ogacq.sim.truth import SimTruth

S_PER_H = 3600.0


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


def joint_travel_mm(truth: SimTruth, axis: int, q_mm: np.ndarray, side: np.ndarray,
                    travel_mm: np.ndarray, t_s: float) -> float:
    """Where joint ``axis`` actually is along its line, from its zero (``rho - L``), the
    joints commanded to ``q_mm`` (3,), each last moved from ``side`` (3,) over
    ``travel_mm`` (3,) since its reversal, at ``t_s``: what a scale along the actuator
    reads up to its own zero. The measurement model's joint position
    (``ogacq.model.measurement``: the encoder scale, the joint offset, its drift and the
    lost motion) written again, of the disturbed ``q``."""
    theta, name = truth.theta, "xyz"[axis]
    q = truth.disturbed_q(np.asarray(q_mm, float), np.asarray(side), np.asarray(travel_mm),
                          t_s)[axis]
    scale = theta[PARAM_INDEX[f"encoder_scale.{name}"]] * 1e-6
    return float(q * (1.0 + scale) + theta[PARAM_INDEX[f"joint_offset.{name}"]]
                 + theta[PARAM_INDEX[f"thermal_drift.{name}"]] * t_s / S_PER_H
                 - 0.5 * side[axis] * theta[PARAM_INDEX[f"backlash.{name}"]])
