"""How every gauge reading moves when a joint centre moves: the exact measurement
model differentiated by the joint centres' positions, per reading.

Errors beyond the library's joint terms (a screw's cyclic error or smooth map, a
hysteresis, a bowed rail) move a joint by an amount that depends on where it is and
how it got there, and a bow moves it across its line. To first order in such a
displacement ``d`` (micrometres on joints 300 mm from the TCP: second order below
1e-7 mm), a reading changes by

    sum over joints a, coordinates c of  at_reading[n, a, c] d_a,c(reading's pose)
                                        + at_setting[n, a, c] d_a,c(gauge's setting pose)

(the leg line the gauge reads; the plane its gauge was set in), differentiated by
hand from ``measurement._evaluate``'s geometry. :func:`predict_displaced` evaluates
it exactly with the joint centres moved: the simulator's bowed rails, and the check
of the first-order model."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ogacq.model.kinematics import forward, forward_tangent, joint_centres
from ogacq.model.machine import MachineSpec
from ogacq.model.measurement import _DRIFT_AT, _GPOS_AT, _GSCALE, ReadingsLayout, _lines, _plan


@dataclass(frozen=True)
class JointSensitivity:
    """(n, 3, 3) derivatives of each reading by joint ``a``'s centre moving along world
    coordinate ``c`` (index ``[n, a, c]``): at the reading's pose and at its gauge's
    setting pose. ``lines`` (3, 3): each actuator line's unit direction (row a)."""

    at_reading: np.ndarray
    at_setting: np.ndarray
    lines: np.ndarray

    def along(self) -> tuple[np.ndarray, np.ndarray]:
        """(n, 3) each, at the reading and at the setting: the derivatives by each joint
        moving along its own line (what a joint-position error does)."""
        return (np.einsum("nac,ac->na", self.at_reading, self.lines),
                np.einsum("nac,ac->na", self.at_setting, self.lines))

    def across(self, joint: int, coordinate: int) -> tuple[np.ndarray, np.ndarray]:
        """(n,) each: the derivatives by joint ``joint`` moving along world coordinate
        ``coordinate`` (a bowed rail moves it across its line)."""
        return self.at_reading[:, joint, coordinate], self.at_setting[:, joint, coordinate]


def _poses(layout: ReadingsLayout, timed: bool) -> np.ndarray:
    """(n + G,) each reading's and then each gauge setting's pose, as the model's
    evaluation plan numbers them."""
    return layout.timed_poses[3] if timed else layout.distinct_poses[2]


def joint_sensitivity(theta: np.ndarray, layout: ReadingsLayout,
                      machine: MachineSpec) -> JointSensitivity:
    """The derivatives of every reading of ``layout`` by the joint centres, at the
    full parameter vector ``theta`` (N,)."""
    th = np.asarray(theta, dtype=float)[None]
    timed = bool(th[0, _DRIFT_AT].any())
    plan = _plan(layout, None, timed)
    rows = _poses(layout, timed)
    n = len(layout)
    u, o, legs = _lines(th, machine.leg_length_mm)
    rho = plan.joint_positions(th, machine.leg_length_mm, None)[0]  # (poses, 3)
    r = joint_centres(rho, u[0][None], o[0][None])  # (poses, 3, 3)
    p = forward(r, legs[0])  # (poses, 3)
    # the nine unit displacements: joint a along coordinate c, k = 3 a + c
    unit = np.eye(9).reshape(9, 3, 3)
    dp = forward_tangent(r, p, legs[0], np.broadcast_to(unit, (len(r), 9, 3, 3)), None)
    at_r, at_s = rows[:n], rows[n:]
    i, j = layout.leg, layout.gauge_axis
    set_leg = np.array([leg for _, leg in layout.gauge_keys], dtype=int)
    gauge = layout.gauge
    pi, pj = p[at_r, i], p[at_r, j]
    ri, rj = r[at_r, i, i], r[at_r, i, j]
    p0 = p[at_s, set_leg][gauge]
    r0 = r[at_s, set_leg, set_leg][gauge]
    frac = th[0, _GPOS_AT[set_leg]][gauge]
    gain = 1.0 + th[0, _GSCALE[j, i]] * 1e-6
    plane = p0 + frac * (r0 - p0)
    span, reach = ri - pi, rj - pj
    mu = (plane - pi) / span

    # moved at the reading's pose: the TCP and the leg's own joint centre move
    dpi, dpj = dp[at_r, :, i], dp[at_r, :, j]  # (n, 9)
    k_ri, k_rj = 3 * i + i, 3 * i + j
    dri = (np.arange(9)[None] == k_ri[:, None]).astype(float)
    drj = (np.arange(9)[None] == k_rj[:, None]).astype(float)
    dmu = (-dpi - mu[:, None] * (dri - dpi)) / span[:, None]
    at_reading = dpj + dmu * reach[:, None] + mu[:, None] * (drj - dpj)
    # moved at the setting pose: the gauge's plane moves, the leg line does not
    s_leg = set_leg[gauge]
    dp0 = dp[at_s[gauge], :, s_leg]  # (n, 9)
    dr0 = (np.arange(9)[None] == (4 * s_leg)[:, None]).astype(float)
    dplane = dp0 + frac[:, None] * (dr0 - dp0)
    at_setting = dplane / span[:, None] * reach[:, None]
    return JointSensitivity((at_reading * gain[:, None]).reshape(n, 3, 3),
                            (at_setting * gain[:, None]).reshape(n, 3, 3), u[0])


def predict_displaced(theta: np.ndarray, layout: ReadingsLayout, machine: MachineSpec,
                      at_reading: np.ndarray, at_setting: np.ndarray) -> np.ndarray:
    """(n,) the readings of ``layout`` (up to each gauge's zero) with each reading's
    joint centres moved by ``at_reading`` (n, 3, 3) [reading, joint, coordinate] mm
    from where ``theta`` puts them, and each gauge's setting pose's by ``at_setting``
    (G, 3, 3): exact, every reading its own pose."""
    th = np.asarray(theta, dtype=float)
    n = len(layout)
    rows = np.arange(n)
    u, o, legs = _lines(th[None], machine.leg_length_mm)
    timed = bool(th[_DRIFT_AT].any())
    plan = _plan(layout, None, timed)
    poses = _poses(layout, timed)  # the joint positions of shared poses, moved per reading
    rho_poses = plan.joint_positions(th[None], machine.leg_length_mm, None)[0]
    rho_r, rho_s = rho_poses[poses[:n]], rho_poses[poses[n:]]
    r_r = joint_centres(rho_r, u[0][None], o[0][None]) + at_reading
    r_s = joint_centres(rho_s, u[0][None], o[0][None]) + at_setting
    p_r, p_s = forward(r_r, legs[0]), forward(r_s, legs[0])
    i, j = layout.leg, layout.gauge_axis
    set_leg = np.array([leg for _, leg in layout.gauge_keys], dtype=int)
    g = np.arange(layout.n_gauges)
    frac = th[_GPOS_AT[set_leg]]
    plane = (p_s[g, set_leg] + frac * (r_s[g, set_leg, set_leg] - p_s[g, set_leg]))
    pi, pj = p_r[rows, i], p_r[rows, j]
    ri, rj = r_r[rows, i, i], r_r[rows, i, j]
    mu = (plane[layout.gauge] - pi) / (ri - pi)
    return (pj + mu * (rj - pj)) * (1.0 + th[_GSCALE[j, i]] * 1e-6)
