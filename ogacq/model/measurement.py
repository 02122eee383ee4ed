"""The exact measurement model: every gauge reading predicted from the geometry.

A gauge is set at its leg's posture of first reading, at ``gauge_position``
(fraction from the TCP end) along the leg, and stays fixed in space. It reads the
coordinate along its axis ``j`` of the leg line where that line crosses the
gauge's plane ``x_i = const`` (``i`` the leg). Its zero is arbitrary, so the
model predicts readings up to one constant per gauge; fits remove it.

Joint ``i`` sits at ``rho_i = L + q_i (1 + scale_i) + drho_i + drift_i t
- approach_i backlash_i / 2`` along its actuator line: ``q`` as commanded, the
encoder zero error, travel scale, offset drift with time, and lost motion
that depends on the side a posture was approached from.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from ogacq.model.gauges import GAUGES, Gauge
from ogacq.model.kinematics import axis_lines, forward, joint_centres, leg_lengths
from ogacq.model.machine import MachineSpec
from ogacq.model.parameters import AXES, PARAM_INDEX

_DRHO = [PARAM_INDEX[f"joint_offset.{a}"] for a in AXES]
_SCALE = [PARAM_INDEX[f"encoder_scale.{a}"] for a in AXES]
_BACKLASH = [PARAM_INDEX[f"backlash.{a}"] for a in AXES]
_DRIFT = [PARAM_INDEX[f"thermal_drift.{a}"] for a in AXES]
_GPOS = [PARAM_INDEX[f"gauge_position.{a}"] for a in AXES]


_GSCALE = {g.indices: PARAM_INDEX[f"gauge_scale.{g.key}"] for g in GAUGES}


def approach_from_sequence(q_mm: np.ndarray) -> np.ndarray:
    """Side each joint approached each reading from: the sign of its last move
    before that reading in the recorded order (0 before any move)."""
    out = np.zeros(q_mm.shape, dtype=int)
    last = np.zeros(3, dtype=int)
    prev = q_mm[0] if len(q_mm) else None
    for k, q in enumerate(q_mm):
        step = np.sign(np.round(q - prev, 9)).astype(int)
        last = np.where(step != 0, step, last)
        out[k] = last
        prev = q
    return out


@dataclass(frozen=True, eq=False)
class ReadingsLayout:
    """Where and when each reading was taken: everything but the values."""

    q_mm: np.ndarray  # (n, 3) joint coordinates as commanded
    leg: np.ndarray  # (n,) 0..2
    gauge_axis: np.ndarray  # (n,) 0..2, never equal to leg
    t_s: np.ndarray  # (n,) seconds since the campaign started
    cycle: np.ndarray  # (n,) repeat index >= 1
    tcp_mm: np.ndarray  # (n, 3) commanded TCP
    approach: np.ndarray  # (n, 3) -1/0/+1 per joint
    gauge: np.ndarray  # (n,) index into gauge_keys
    gauge_keys: tuple[tuple[int, int], ...]  # (gauge_axis, leg) per gauge
    setting_q_mm: np.ndarray  # (G, 3) posture each gauge was set at
    # (n,) the plan's posture labels ("zero", "max", "+12mm"), None when not recorded
    posture: np.ndarray | None = None

    @classmethod
    def build(cls, q_mm, leg, gauge_axis, t_s=None, cycle=None, tcp_mm=None,
              approach=None, posture=None) -> ReadingsLayout:
        q = np.asarray(q_mm, dtype=float).reshape(-1, 3)
        n = len(q)
        leg = np.asarray(leg, dtype=int)
        axis = np.asarray(gauge_axis, dtype=int)
        if np.any(leg == axis):
            raise ValueError("a gauge cannot measure along its own leg's axis")
        keys: list[tuple[int, int]] = []
        gauge = np.empty(n, dtype=int)
        setting = []
        for k in range(n):
            key = (int(axis[k]), int(leg[k]))
            if key not in keys:
                keys.append(key)
                setting.append(q[k])
            gauge[k] = keys.index(key)
        return cls(
            q_mm=q, leg=leg, gauge_axis=axis,
            t_s=np.zeros(n) if t_s is None else np.asarray(t_s, dtype=float),
            cycle=np.ones(n, dtype=int) if cycle is None else np.asarray(cycle, dtype=int),
            tcp_mm=np.full((n, 3), np.nan) if tcp_mm is None else np.asarray(tcp_mm, float),
            approach=approach_from_sequence(q) if approach is None
            else np.asarray(approach, dtype=int),
            gauge=gauge, gauge_keys=tuple(keys),
            setting_q_mm=np.array(setting).reshape(-1, 3),
            posture=None if posture is None else np.asarray(posture, dtype=object),
        )

    def __len__(self) -> int:
        return len(self.q_mm)

    @property
    def n_gauges(self) -> int:
        return len(self.gauge_keys)

    def gauge_names(self) -> list[str]:
        return [Gauge.at(j, i).key for j, i in self.gauge_keys]

    @cached_property
    def distinct_poses(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Poses of the readings and then the gauge settings, each solved once:
        (unique q (u, 3), unique approach (u, 3), index (n + G,) into them).
        Time is left out; it only matters when thermal drift is modelled."""
        q = np.concatenate([self.q_mm, self.setting_q_mm])
        appr = np.concatenate([self.approach, np.zeros((self.n_gauges, 3), dtype=int)])
        key = np.column_stack([np.round(q, 9), appr])
        unique, index = np.unique(key, axis=0, return_inverse=True)
        return unique[:, :3], unique[:, 3:].astype(int), index.ravel()

    def subset(self, mask: np.ndarray) -> ReadingsLayout:
        """The readings selected by ``mask``. Each kept gauge keeps the posture it was
        set at, even when the reading taken there is dropped."""
        idx = np.flatnonzero(mask)
        kept = list(dict.fromkeys(self.gauge[idx].tolist()))  # in order of appearance
        renumber = {old: new for new, old in enumerate(kept)}
        return ReadingsLayout(
            q_mm=self.q_mm[idx], leg=self.leg[idx], gauge_axis=self.gauge_axis[idx],
            t_s=self.t_s[idx], cycle=self.cycle[idx], tcp_mm=self.tcp_mm[idx],
            approach=self.approach[idx],
            gauge=np.array([renumber[g] for g in self.gauge[idx]], dtype=int),
            gauge_keys=tuple(self.gauge_keys[g] for g in kept),
            setting_q_mm=self.setting_q_mm[kept].reshape(-1, 3),
            posture=None if self.posture is None else self.posture[idx])

    def posture_names(self, machine: MachineSpec) -> np.ndarray:
        """(n,) each reading's posture: as recorded, else (a readings CSV has no posture
        column) zero, max or min where the commanded TCP along the leg is one of them."""
        if self.posture is not None:
            return self.posture
        along = self.tcp_mm[np.arange(len(self)), self.leg]
        out = np.full(len(self), "", dtype=object)
        for name in POSTURE_NAMES:
            out[np.isclose(along, posture_tcp(0, name, machine)[0], atol=1e-6)] = name
        return out


def _joint_positions(theta, q, t_s, approach, machine: MachineSpec):
    """(B, m, 3) joint positions along their lines."""
    scale = theta[:, None, _SCALE] * 1e-6
    drho = theta[:, None, _DRHO]
    drift = theta[:, None, _DRIFT] / 3600.0
    backlash = theta[:, None, _BACKLASH]
    return (machine.leg_length_mm + q[None] * (1.0 + scale) + drho
            + drift * t_s[None, :, None] - 0.5 * approach[None] * backlash)


def predict_coordinates(theta: np.ndarray, layout: ReadingsLayout,
                        machine: MachineSpec) -> np.ndarray:
    """Predicted gauge readings up to each gauge's zero: (B, n), or (n,) for 1-D theta.

    NaN marks readings whose posture the legs cannot reach.
    """
    theta = np.asarray(theta, dtype=float)
    single = theta.ndim == 1
    th = theta[None] if single else theta
    n, g = len(layout), layout.n_gauges
    if np.any(th[:, _DRIFT] != 0):
        # Drift makes every reading's pose its own: solve them all.
        q = np.concatenate([layout.q_mm, layout.setting_q_mm])
        t = np.concatenate([layout.t_s, np.zeros(g)])
        appr = np.concatenate([layout.approach, np.zeros((g, 3), dtype=int)])
        rows = np.arange(n + g)
    else:
        q, appr, rows = layout.distinct_poses
        t = np.zeros(len(q))
    rho = _joint_positions(th, q, t, appr, machine)
    u, o = axis_lines(th)
    r_poses = joint_centres(rho, u[:, None], o[:, None])  # (B, poses, 3, 3)
    legs = leg_lengths(th, machine.leg_length_mm)[:, None, :]
    p_poses = forward(r_poses, np.broadcast_to(legs, r_poses.shape[:-1]))
    r, p = r_poses[:, rows], p_poses[:, rows]  # (B, n + G, ...): readings, then settings

    set_leg = np.array([i for _, i in layout.gauge_keys], dtype=int)
    gidx = np.arange(g)
    p0 = p[:, n + gidx, set_leg]
    r0 = r[:, n + gidx, set_leg, set_leg]
    frac = th[:, _GPOS][:, set_leg]
    plane = p0 + frac * (r0 - p0)  # (B, G): the gauge's fixed coordinate along its leg

    k = np.arange(n)
    i, j = layout.leg, layout.gauge_axis
    pi, pj = p[:, k, i], p[:, k, j]
    ri = r[:, k, i, i]
    rj = r[:, k, i, j]
    mu = (plane[:, layout.gauge] - pi) / (ri - pi)
    coord = pj + mu * (rj - pj)
    gscale = th[:, [_GSCALE[(int(a), int(b))] for a, b in zip(j, i, strict=True)]]
    out = coord * (1.0 + gscale * 1e-6)
    return out[0] if single else out


# --- postures and the papers' protocol -------------------------------------------------

POSTURE_NAMES = ("zero", "max", "min")


def posture_tcp(leg: int, posture: str | float, machine: MachineSpec) -> np.ndarray:
    """Commanded TCP of a posture of a leg's test: along the leg's own axis."""
    if isinstance(posture, str):
        s = {"zero": 0.0, "max": machine.rho_max_mm, "min": machine.rho_min_mm}[posture]
    else:
        s = float(posture)
    p = np.zeros(3)
    p[leg] = s
    return p
