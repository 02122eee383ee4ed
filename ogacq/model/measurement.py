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

from collections.abc import Sequence
from dataclasses import dataclass, replace
from functools import cached_property, lru_cache
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:  # numpy.typing: 1 ms of start-up for annotations only
    from numpy.typing import ArrayLike

from ogacq.model.gauges import GAUGES, Gauge
from ogacq.model.kinematics import (
    axis_line_tangents,
    axis_lines,
    forward,
    forward_tangent,
    joint_centres,
    leg_length_tangents,
    leg_lengths,
)
from ogacq.model.machine import MachineSpec
from ogacq.model.parameters import AXES, AXIS_PAIRS, NOMINAL, PARAM_INDEX, indices

# [gauge axis, leg] -> position of that gauge's scale in the parameter vector
_GSCALE = np.zeros((3, 3), dtype=int)
for _gauge in GAUGES:
    _GSCALE[_gauge.indices] = PARAM_INDEX[f"gauge_scale.{_gauge.key}"]


def approach_from_sequence(q_mm: np.ndarray) -> np.ndarray:
    """Side each joint approached each reading from: the sign of its last move
    before that reading in the recorded order (moves below 1e-9 mm are none);
    0, unknown, before its first recorded move. Each joint's moves found at once
    and their signs repeated over the readings until its next move."""
    q = np.asarray(q_mm, dtype=float).reshape(-1, 3)
    n = len(q)
    out = np.zeros((n, 3), dtype=int)
    if n < 2:
        return out
    # np.sign(np.round(d, 9)): np.round is rint(d * 1e9) / 1e9, and rint (halves to
    # even) gives a positive number exactly when its argument exceeds 0.5
    nanometres = np.diff(q, axis=0) * 1e9  # (n - 1, 3)
    steps = (nanometres > 0.5).astype(int) - (nanometres < -0.5)
    for joint in range(3):
        moved = np.flatnonzero(steps[:, joint])
        if len(moved):
            # the move between readings k and k + 1 holds from reading k + 1 on
            lengths = np.diff(np.append(moved, n - 1))
            out[moved[0] + 1:, joint] = np.repeat(steps[moved, joint], lengths)
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
    # (n, 3) the side each joint's lost motion acts from, where it differs from the
    # recorded approach: a side unknown before a joint's first recorded move (0) that
    # the diagnosis resolved (``diagnose/sides.py``); None: the approach. Repeats are
    # grouped by the recorded approach all the same.
    side: np.ndarray | None = None

    @classmethod
    def build(cls, q_mm: ArrayLike, leg: ArrayLike, gauge_axis: ArrayLike,
              t_s: ArrayLike | None = None, cycle: ArrayLike | None = None,
              tcp_mm: ArrayLike | None = None, approach: ArrayLike | None = None,
              posture: Sequence[str | None] | np.ndarray | None = None) -> ReadingsLayout:
        q = np.asarray(q_mm, dtype=float).reshape(-1, 3)
        n = len(q)
        leg = np.asarray(leg, dtype=int)
        axis = np.asarray(gauge_axis, dtype=int)
        if np.any(leg == axis):
            raise ValueError("a gauge cannot measure along its own leg's axis")
        # gauges numbered in order of first reading, each set where it first read
        code = axis * 3 + leg
        codes, first, which = np.unique(code, return_index=True, return_inverse=True)
        order = np.argsort(first)
        number = np.empty(len(codes), dtype=int)
        number[order] = np.arange(len(codes))
        gauge = number[which.ravel()]
        keys = [(int(c) // 3, int(c) % 3) for c in codes[order]]
        setting = q[first[order]]
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
    def lost_motion_side(self) -> np.ndarray:
        """(n, 3) the side the model's lost motion takes at each reading."""
        return self.approach if self.side is None else self.side

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
        appr = np.concatenate([self.lost_motion_side, np.zeros((self.n_gauges, 3), dtype=int)])
        key = np.column_stack([np.round(q, 9), appr])
        unique, index = unique_rows(key)
        return unique[:, :3], unique[:, 3:].astype(int), index

    @cached_property
    def repeat_group(self) -> np.ndarray:
        """(n,) each reading's group of repeats: same gauge, same joint coordinates,
        same approach side (the cycles of one posture). Computed once per layout:
        every weighting and noise estimate of these readings asks for it."""
        keys = np.column_stack([self.gauge, np.round(self.q_mm, 6), self.approach])
        return unique_rows(keys)[1]

    @cached_property
    def repeat_size(self) -> np.ndarray:
        """(groups,) how many readings each repeat group holds (int)."""
        return np.bincount(self.repeat_group)

    @cached_property
    def repeat_order(self) -> tuple[np.ndarray, np.ndarray]:
        """The readings ordered group by group (stable) and where each group starts in
        that order: sums per group as one ``np.add.reduceat``."""
        order = np.argsort(self.repeat_group, kind="stable")
        starts = np.concatenate([[0], np.cumsum(self.repeat_size[:-1])]).astype(int)
        return order, starts

    @cached_property
    def timed_poses(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """As :attr:`distinct_poses`, time included (thermal drift makes it matter):
        (unique q, unique approach, unique t, index (n + G,)). The gauges of one
        posture are read at one time, so they still share a pose."""
        q = np.concatenate([self.q_mm, self.setting_q_mm])
        appr = np.concatenate([self.lost_motion_side, np.zeros((self.n_gauges, 3), dtype=int)])
        t = np.concatenate([self.t_s, np.zeros(self.n_gauges)])
        key = np.column_stack([np.round(q, 9), appr, t])
        unique, index = unique_rows(key)
        return unique[:, :3], unique[:, 3:6].astype(int), unique[:, 6], index

    @cached_property
    def gauge_onehot(self) -> np.ndarray:
        """(n, G) 1 where a reading is its gauge's: sums and means per gauge as one
        product (a gauge's unknown zero is removed this way at every fit)."""
        return np.eye(self.n_gauges)[self.gauge]

    @cached_property
    def gauge_counts(self) -> np.ndarray:
        """(G,) how many readings each gauge took (float: ``gauge_onehot.sum(axis=0)``)."""
        return self.gauge_onehot.sum(axis=0)

    @cached_property
    def evaluation_poses(self) -> dict:
        """The poses' indices every evaluation plan of these readings shares
        (``_PoseIndex``), by whether time matters."""
        return {}

    @cached_property
    def evaluation_plans(self) -> dict:
        """The model's evaluation plans for these readings (``_plan``), most recently
        used last: what a fit's repeated evaluations share."""
        return {}

    def with_side(self, side: np.ndarray) -> ReadingsLayout:
        """This layout with the model's lost-motion ``side`` replaced. What it has
        computed of the rest (repeat groups, which are the recorded approach's, and
        the gauges' one-hot) is the same and is shared, not computed again."""
        out = replace(self, side=side)
        for name in _SIDE_FREE:
            if name in self.__dict__:  # computed (functools.cached_property keeps it there)
                out.__dict__[name] = self.__dict__[name]
        return out

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
            posture=None if self.posture is None else self.posture[idx],
            side=None if self.side is None else self.side[idx])

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


# ReadingsLayout's computed properties that do not read ``side`` (``with_side``)
_SIDE_FREE = ("repeat_group", "repeat_size", "repeat_order", "gauge_onehot", "gauge_counts")


# the parameters' positions as index arrays: numpy gathers with them without converting
# a list
_DRHO_AT, _SCALE_AT, _BACKLASH_AT, _DRIFT_AT, _GPOS_AT, _LEG_LENGTH_AT = (
    indices(f"{kind}.{a}" for a in AXES) for kind in (
        "joint_offset", "encoder_scale", "backlash", "thermal_drift", "gauge_position",
        "leg_length"))
_SQUARENESS_AT, _AXIS_OFFSET_AT = (indices(f"{kind}.{w}" for w in AXIS_PAIRS)
                                   for kind in ("squareness", "axis_offset"))
# the entries of the joint positions but the offsets
_JOINT_TERMS_AT = np.concatenate([_SCALE_AT, _DRIFT_AT, _BACKLASH_AT])


def unique_rows(keys: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``np.unique(keys, axis=0, return_inverse=True)``, the same rows in the same
    (lexicographic) order and the same inverse, by one lexsort: np.unique sorts the
    rows as structured records, 23x slower (72,000 readings: 139 ms against 6)."""
    if len(keys) == 0 or np.isnan(keys).any():  # NaN rows: np.unique's own rules
        unique, inverse = np.unique(keys, axis=0, return_inverse=True)
        return unique, inverse.ravel()
    order = np.lexsort(keys.T[::-1])  # lexsort's last key is the primary one
    ordered = keys[order]
    new = np.any(ordered[1:] != ordered[:-1], axis=1)
    inverse = np.empty(len(keys), dtype=np.intp)
    inverse[order] = np.concatenate([[0], np.cumsum(new)])
    return ordered[np.concatenate([[0], np.flatnonzero(new) + 1])], inverse


def as_slice(at: np.ndarray) -> np.ndarray | slice:
    """``at`` as a slice when its positions are consecutive: indexing with it is a
    view, where an index array gathers a copy (a fit indexes small vectors often)."""
    positions = np.asarray(at).tolist()
    if positions and positions == list(range(positions[0], positions[0] + len(positions))):
        return slice(positions[0], positions[0] + len(positions))
    return np.asarray(at)


# the offsets' and drifts' positions, consecutive in the parameter vector
_DRHO_SLICE, _DRIFT_SLICE = as_slice(_DRHO_AT), as_slice(_DRIFT_AT)
# every entry axis_lines and leg_lengths read
_GEOMETRY_AT = np.concatenate([_SQUARENESS_AT, _AXIS_OFFSET_AT, _LEG_LENGTH_AT])
# every gauge's gain
_GSCALE_AT = np.array(sorted({int(_GSCALE[g.indices]) for g in GAUGES}))
_SQUARENESS_SET, _AXIS_OFFSET_SET, _DRIFT_SET, _GSCALE_SET = (
    frozenset(at.tolist()) for at in (_SQUARENESS_AT, _AXIS_OFFSET_AT, _DRIFT_AT, _GSCALE_AT))


def _joint_position_tangents(q: np.ndarray, approach: np.ndarray, free: np.ndarray,
                             ) -> np.ndarray:
    """(m, P, 3) derivatives of the joint positions (``_EvaluationPlan.joint_positions``)
    by the ``free`` parameters.
    A drift's derivative is ``t / 3600``, different for every reading: it is given
    here as 1 (an offset's) and scaled by each reading's time once the poses are
    mapped to readings, so that poses stay shared across readings."""
    out = np.zeros((len(q), len(free), 3))
    for k, index in enumerate(free):
        for a in range(3):
            if index in (_DRHO_AT[a], _DRIFT_AT[a]):
                out[:, k, a] = 1.0
            elif index == _SCALE_AT[a]:
                out[:, k, a] = q[:, a] * 1e-6
            elif index == _BACKLASH_AT[a]:
                out[:, k, a] = -0.5 * approach[:, a]
    return out


class _Fixed:
    """The parts of an evaluation that read only entries a fit leaves as they were
    (``_EvaluationPlan.fixed``), for one value of those entries. None where a part
    is not remembered (it reads a free entry, or it is too large to keep)."""

    __slots__ = ("key", "leg_length_mm", "lines", "joint_terms", "frac", "gain", "unit_gain",
                 "dr")

    def __init__(self, key: np.ndarray, leg_length_mm: float) -> None:
        self.key, self.leg_length_mm = key, leg_length_mm
        self.lines: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None
        # (scaled, drifted, lost) of the joint positions; drifted and lost None when zero
        self.joint_terms: tuple[np.ndarray, np.ndarray | None, np.ndarray | None] | None = None
        self.frac: np.ndarray | None = None
        self.gain: np.ndarray | None = None
        self.unit_gain = False  # every gain exactly 1: multiplying by it changes nothing
        # the joint centres' derivatives (B, poses, P, 3, 3) and those the readings need:
        # along the leg (B, n, P), along the gauge axis, at the gauge settings (B, G, P)
        self.dr: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray] | None = None

    def matches(self, key: np.ndarray, leg_length_mm: float) -> bool:
        return self.leg_length_mm == leg_length_mm and self.key.shape == key.shape \
            and bool((self.key == key).all())


class _PoseIndex:
    """What every evaluation plan of a layout shares, whatever is free: the distinct
    poses, and where each reading and gauge setting finds its coordinates among them
    (flat indices, one gather each). Built once per layout and whether drift makes
    time matter (``ReadingsLayout.evaluation_poses``)."""

    __slots__ = ("q", "appr", "t", "n", "gauge", "p_index", "r_index", "gauge_position",
                 "gauge_scale")

    def __init__(self, layout: ReadingsLayout, timed: bool) -> None:
        n = len(layout)
        if timed:  # drift: a pose per reading time
            self.q, self.appr, self.t, rows = layout.timed_poses
        else:
            self.q, self.appr, rows = layout.distinct_poses
            self.t = np.zeros(len(self.q))
        self.n = n
        at_reading, at_setting = rows[:n], rows[n:]
        set_leg = np.array([i for _, i in layout.gauge_keys], dtype=int)
        i, j = layout.leg, layout.gauge_axis
        self.gauge = layout.gauge
        # into p (B, poses * 3), one gather: the reading pose's TCP along the leg (pi),
        # then along the gauge axis (pj), then the setting pose's along the set leg (p0)
        self.p_index = np.concatenate([at_reading * 3 + i, at_reading * 3 + j,
                                       at_setting * 3 + set_leg])
        # into r (B, poses * 9), joint then coordinate: the leg's joint centre along
        # the leg (ri) and the gauge axis (rj), the set leg's along itself (r0)
        self.r_index = np.concatenate([at_reading * 9 + i * 4, at_reading * 9 + i * 3 + j,
                                       at_setting * 9 + set_leg * 4])
        self.gauge_position = _GPOS_AT[set_leg]  # (G,)
        self.gauge_scale = _GSCALE[j, i]  # (n,)


def _pose_index(layout: ReadingsLayout, timed: bool) -> _PoseIndex:
    known = layout.evaluation_poses
    index = known.get(timed)
    if index is None:
        index = known[timed] = _PoseIndex(layout, timed)
    return index


class _FreeSet:
    """What an evaluation plan needs of its free set alone, whatever the layout:
    which parts of an evaluation read no free entry (remembered between
    evaluations, keyed on the entries they read), and the derivatives and columns
    that are constants (line offsets, leg lengths, which columns are drifts or
    gains). Made once per free set (``_free_set``) and shared by the plans of every
    layout, so its arrays are read-only."""

    def __init__(self, free: tuple[int, ...] | None) -> None:
        free_entries = set() if free is None else set(free)
        self.keeps_lines, self.keeps_joint_terms, self.keeps_frac, self.keeps_gain = (
            free_entries.isdisjoint(at.tolist())
            for at in (_GEOMETRY_AT, _JOINT_TERMS_AT, _GPOS_AT, _GSCALE_AT))
        self.key_at = as_slice(np.sort(np.concatenate(
            [at for at, kept in ((_GEOMETRY_AT, self.keeps_lines),
                                 (_JOINT_TERMS_AT, self.keeps_joint_terms),
                                 (_GPOS_AT, self.keeps_frac), (_GSCALE_AT, self.keeps_gain))
             if kept] + [np.zeros(0, dtype=int)])))
        self.free: np.ndarray | None = None
        if free is None:
            return
        fr = _read_only(np.array(free, dtype=int))
        self.free = fr
        # which free entries are of which kind, by set lookups over the few free
        # positions (np.isin costs more than a small plan's arithmetic)
        self.tilts = not _SQUARENESS_SET.isdisjoint(free)
        self.do = _read_only(axis_line_tangents(NOMINAL[None], fr)[1]) \
            if not _AXIS_OFFSET_SET.isdisjoint(free) else None
        dlegs = leg_length_tangents(fr)
        self.dlegs = _read_only(dlegs) if dlegs.any() else None
        drift = np.array([k in _DRIFT_SET for k in free], dtype=bool)
        self.drifts = bool(drift.any())
        # gauges are set at t = 0: no drift there; a reading's drift derivative is
        # its time (see _joint_position_tangents). None: no drift free.
        self.set_without_drift = _read_only(~drift) if self.drifts else None
        self.drift_columns = _read_only(np.flatnonzero(drift))
        # (not _GSCALE: its unused diagonal holds 0, a joint offset's position)
        self.gain_columns = _read_only(np.array(
            [c for c, k in enumerate(free) if k in _GSCALE_SET], dtype=np.intp))


@lru_cache(maxsize=256)
def _free_set(free: tuple[int, ...] | None) -> _FreeSet:
    """:class:`_FreeSet` of ``free``, a pure function of it: a diagnosis asks for the
    same free sets on several layouts (the readings, their repeat groups, a side
    resolved)."""
    return _FreeSet(free)


def _read_only(a: np.ndarray) -> np.ndarray:
    a.setflags(write=False)
    return a


class _EvaluationPlan:
    """What :func:`_evaluate` needs of a layout that no parameter value changes: its
    poses' indices (:class:`_PoseIndex`), and for a free set the derivatives that
    are constants (joint positions, line offsets, leg lengths, which readings a
    drift, gauge position or gain acts on; :class:`_FreeSet`). Built once per
    layout, free set and whether drift makes time matter; a fit evaluates the model
    a handful of times with the same ones, so none of it is redone per evaluation."""

    def __init__(self, layout: ReadingsLayout, free: tuple[int, ...] | None,
                 timed: bool) -> None:
        poses = _pose_index(layout, timed)
        self.q, self.appr, self.t, self.n, self.gauge = \
            poses.q, poses.appr, poses.t, poses.n, poses.gauge
        self.p_index, self.r_index = poses.p_index, poses.r_index
        self.gauge_position, self.gauge_scale = poses.gauge_position, poses.gauge_scale
        # the parts remembered between evaluations: those that read no free entry
        # (a fit changes only those), keyed on the entries they read
        kind = _free_set(free)
        self.keeps_lines, self.keeps_joint_terms, self.keeps_frac, self.keeps_gain = \
            kind.keeps_lines, kind.keeps_joint_terms, kind.keeps_frac, kind.keeps_gain
        self.key_at = kind.key_at
        self._fixed: _Fixed | None = None
        self.free: np.ndarray | None = kind.free
        if kind.free is None:
            return
        fr = kind.free
        self.drho = _joint_position_tangents(self.q, self.appr, fr)  # (poses, P, 3)
        self.tilts, self.do, self.dlegs = kind.tilts, kind.do, kind.dlegs
        self.set_without_drift = kind.set_without_drift
        # only the columns a drift or a gauge's gain acts on, each (n,) per column: a
        # (n, P) array of ones and zeros would cost a long campaign megabytes per plan
        self.drift_columns = kind.drift_columns
        # a reading's hours, for its coordinates along the leg and the gauge axis
        self.hours = np.tile(layout.t_s / 3600.0, 2)[:, None] if kind.drifts else None
        dfrac = (fr[None, :] == self.gauge_position[:, None]).astype(float)  # (G, P)
        self.dfrac = dfrac if dfrac.any() else None
        self.gain_columns = kind.gain_columns
        self.dgain = (fr[self.gain_columns][None, :] == self.gauge_scale[:, None]) * 1e-6 \
            if len(self.gain_columns) else None  # (n, columns)

    def fixed(self, th: np.ndarray, leg_length_mm: float) -> _Fixed:
        """The remembered parts for ``th``: those of the last call when the entries
        they read are the same (every evaluation of a fit but the first), else made
        now. Each part is kept only while small: what it saves is numpy calls, which
        matter only where the arrays are small (a batch over a long campaign's
        poses is not)."""
        key = th[:, self.key_at]
        last = self._fixed  # read once: another thread may replace it meanwhile
        if last is not None and last.matches(key, leg_length_mm):
            return last
        made = _Fixed(key.copy(), leg_length_mm)  # a view of th, which its caller may change
        # a part too large to keep is not made here: the evaluation makes it, once
        batch = len(th)
        if self.keeps_lines:  # (B, 3, 3): always small enough
            made.lines = _lines(th, leg_length_mm)
        if self.keeps_joint_terms and batch * len(self.q) * 3 <= _REMEMBERED_SIZE:
            scaled, drifted, lost = self.joint_terms(th, leg_length_mm)
            made.joint_terms = (scaled, drifted if drifted.any() else None,
                                lost if lost.any() else None)
        if self.keeps_frac and batch * len(self.gauge_position) <= _REMEMBERED_SIZE:
            made.frac = th[:, self.gauge_position]
        if self.keeps_gain and batch * self.n <= _REMEMBERED_SIZE:
            made.gain = 1.0 + th[:, self.gauge_scale] * 1e-6
            made.unit_gain = bool((made.gain == 1.0).all())
        if made.lines is not None and self.free is not None and \
                batch * len(self.r_index) * len(self.free) <= _REMEMBERED_SIZE:
            made.dr = self.joint_centre_tangents(th, made.lines[0])
        self._fixed = made
        return made

    def joint_terms(self, th: np.ndarray, leg_length_mm: float,
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The joint positions' terms but the offsets (the module's formula for ``rho``):
        (B, poses, 3) each, scaled travel, drift and half the lost motion."""
        scale = th[:, None, _SCALE_AT] * 1e-6
        drift = th[:, None, _DRIFT_SLICE] / 3600.0
        backlash = th[:, None, _BACKLASH_AT]
        return (leg_length_mm + self.q[None] * (1.0 + scale), drift * self.t[None, :, None],
                0.5 * self.appr[None] * backlash)

    def joint_positions(self, th: np.ndarray, leg_length_mm: float,
                        terms: tuple[np.ndarray, np.ndarray | None, np.ndarray | None] | None,
                        ) -> np.ndarray:
        """(B, poses, 3) joint positions along their lines; ``terms``: the remembered
        ones (None: made here). A zero term is not added: it would change no digit."""
        if terms is None:
            travel, drift, backlash = self.joint_terms(th, leg_length_mm)
            return travel + th[:, None, _DRHO_SLICE] + drift - backlash
        scaled, drifted, lost = terms
        rho = scaled + th[:, None, _DRHO_SLICE]
        if drifted is not None:
            rho = rho + drifted
        return rho if lost is None else rho - lost

    def joint_centre_tangents(self, th: np.ndarray, u: np.ndarray,
                              rho: np.ndarray | None = None,
                              ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """The joint centres' derivatives by the free parameters (B, poses, P, 3, 3)
        and those the readings need, gathered (see :class:`_Fixed`); ``rho``: the
        joint positions, needed when a squareness is free."""
        batch, n, free = len(th), self.n, self.free
        assert free is not None
        dr_poses = self.drho[None, :, :, :, None] * u[:, None, None]  # (B, poses, P, 3, 3)
        if self.do is not None:
            dr_poses = self.do + dr_poses
        if self.tilts:
            assert rho is not None
            dr_poses = dr_poses + rho[:, :, None, :, None] * \
                axis_line_tangents(th, free)[0][:, None]
        dr_flat = dr_poses.transpose(0, 1, 3, 4, 2).reshape(batch, -1, len(free))
        dr_at = dr_flat[:, self.r_index]  # gathers copy: scaled in place
        dr0 = dr_at[:, 2 * n:]
        if self.hours is not None:
            dr0 = dr0 * self.set_without_drift
            dr_at[:, :2 * n, self.drift_columns] *= self.hours
        return dr_poses, dr_at[:, :n], dr_at[:, n:2 * n], dr0


# Largest array (elements) a plan remembers from one evaluation for the next.
_REMEMBERED_SIZE = 30_000


# Plans kept per layout: a diagnosis asks for a few free sets in turn; a long campaign's
# plans hold arrays as long as its readings, so only the latest few are kept.
_PLANS_KEPT = 4


def _plan(layout: ReadingsLayout, free: np.ndarray | None, timed: bool) -> _EvaluationPlan:
    plans = layout.evaluation_plans
    key = (None if free is None else tuple(free.tolist()), timed)
    plan = plans.pop(key, None)
    if plan is None:
        plan = _EvaluationPlan(layout, key[0], timed)
        while len(plans) >= _PLANS_KEPT:
            plans.pop(next(iter(plans)))
    plans[key] = plan  # most recently used last
    return plan


def predict_coordinates(theta: np.ndarray, layout: ReadingsLayout,
                        machine: MachineSpec) -> np.ndarray:
    """Predicted gauge readings up to each gauge's zero: (B, n), or (n,) for 1-D theta;
    NaN where the legs cannot reach the posture."""
    theta = np.asarray(theta, dtype=float)
    out, _ = _evaluate(theta[None] if theta.ndim == 1 else theta, layout, machine, None)
    return out[0] if theta.ndim == 1 else out


def predict_jacobian(theta: np.ndarray, layout: ReadingsLayout, machine: MachineSpec,
                     free: np.ndarray) -> np.ndarray:
    """(B, n, P) analytic derivatives of :func:`predict_coordinates` by the parameters
    at positions ``free`` of the full vector, for theta (B, N)."""
    return predict_and_jacobian(theta, layout, machine, free)[1]


def predict_and_jacobian(theta: np.ndarray, layout: ReadingsLayout, machine: MachineSpec,
                         free: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:func:`predict_coordinates` (B, n) and :func:`predict_jacobian` (B, n, P) at once."""
    out, jac = _evaluate(np.asarray(theta, dtype=float), layout, machine,
                         np.asarray(free, dtype=int))
    assert jac is not None
    return out, jac


def _lines(th: np.ndarray, leg_length_mm: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`axis_lines` ``u``, ``o`` (B, 3, 3) and the leg lengths (B, 1, 3) of ``th``."""
    u, o = axis_lines(th)
    return u, o, leg_lengths(th, leg_length_mm)[:, None, :]


def _evaluate(th: np.ndarray, layout: ReadingsLayout, machine: MachineSpec,
              free: np.ndarray | None) -> tuple[np.ndarray, np.ndarray | None]:
    """The predictions (B, n) and, when ``free`` is given, their derivatives (B, n, P):
    one pass through the same intermediate values, so the two cannot disagree."""
    plan = _plan(layout, free, bool(th[:, _DRIFT_SLICE].any()))
    n, batch = plan.n, len(th)
    leg_length_mm = machine.leg_length_mm
    fixed = plan.fixed(th, leg_length_mm)
    u, o, legs = _lines(th, leg_length_mm) if fixed.lines is None else fixed.lines
    rho = plan.joint_positions(th, leg_length_mm, fixed.joint_terms)
    r_poses = joint_centres(rho, u[:, None], o[:, None])  # (B, poses, 3, 3)
    p_poses = forward(r_poses, legs)

    # (B, n) or (B, G) the coordinates the readings need (see _EvaluationPlan)
    p_at = p_poses.reshape(batch, -1)[:, plan.p_index]
    r_at = r_poses.reshape(batch, -1)[:, plan.r_index]
    pi, pj, p0 = p_at[:, :n], p_at[:, n:2 * n], p_at[:, 2 * n:]
    ri, rj, r0 = r_at[:, :n], r_at[:, n:2 * n], r_at[:, 2 * n:]

    frac = th[:, plan.gauge_position] if fixed.frac is None else fixed.frac
    plane = p0 + frac * (r0 - p0)  # (B, G): the gauge's fixed coordinate along its leg
    span, reach = ri - pi, rj - pj
    mu = (plane[:, plan.gauge] - pi) / span
    coord = pj + mu * reach
    if fixed.unit_gain:  # times 1.0: the same doubles
        gain = None
        out = coord
    else:
        gain = 1.0 + th[:, plan.gauge_scale] * 1e-6 if fixed.gain is None else fixed.gain
        out = coord * gain
    if free is None:
        return out, None

    # Forward-mode derivatives of every step above. Terms a free set cannot have
    # (no tilt, no line offset, no drift, no gauge position or gain free) are left
    # out rather than added as zeros.
    dr_poses, dri, drj, dr0 = plan.joint_centre_tangents(th, u, rho) if fixed.dr is None \
        else fixed.dr
    dp_poses = forward_tangent(r_poses, p_poses, legs, dr_poses, plan.dlegs)
    # parameter axis last and poses with coordinates flat, so that one gather gives
    # (B, n|G, P) as above
    dp_at = dp_poses.transpose(0, 1, 3, 2).reshape(batch, -1, len(free))[:, plan.p_index]
    dp0 = dp_at[:, 2 * n:]
    if plan.hours is not None:  # gathers copy: scaled in place
        dp0 = dp0 * plan.set_without_drift
        dp_at[:, :2 * n, plan.drift_columns] *= plan.hours
    dpi, dpj = dp_at[:, :n], dp_at[:, n:2 * n]

    if plan.dfrac is None:
        dplane = dp0 + frac[..., None] * (dr0 - dp0)
    else:
        dplane = dp0 + plan.dfrac * (r0 - p0)[..., None] + frac[..., None] * (dr0 - dp0)
    mu_ = mu[..., None]
    dmu = (dplane[:, plan.gauge] - dpi - mu_ * (dri - dpi)) / span[..., None]
    dcoord = dpj + dmu * reach[..., None] + mu_ * (drj - dpj)
    jac = dcoord if gain is None else dcoord * gain[..., None]
    if plan.dgain is not None:
        jac[..., plan.gain_columns] += coord[..., None] * plan.dgain
    return out, jac


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
