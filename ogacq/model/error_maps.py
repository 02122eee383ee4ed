"""Errors of an axis beyond the effect library: their shapes along the joint
coordinate ``q``, with the approach side, the travel since the last reversal, and
time (the errors ISO 230-2:2014 measures position by position, in both directions).

The families (cyclic lead-screw error, smooth screw map, hysteresis, rail bow,
warm-up) are one module each in ``ogacq/model/families/`` (``FAMILIES``,
``families/base.py``). Here: each joint's history at each reading, and the table
(``AxisMap``) of an axis's fitted terms. A term is linear in its amplitudes once
its shape is fixed; every along-the-line term is zero at the reference approached
forward (its constant is the joint offset's). Sign: actual minus commanded, as in
``AxisMap``."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from ogacq.model.axis_map import AxisMap
from ogacq.model.families import FAMILIES as FAMILIES
from ogacq.model.families import MapTerm as MapTerm
from ogacq.model.families.smooth import cubic_bspline as cubic_bspline
from ogacq.model.gauges import AXES
from ogacq.model.measurement import ReadingsLayout

# The overshoot of a plan's approach moves when a layout does not say it (the
# default of ``ProtocolConfig.overshoot_mm``; no source beyond the plan): the travel
# since the reversal hidden in an approach from below or above.
DEFAULT_OVERSHOOT_MM = 1.0


@dataclass(frozen=True, eq=False)
class JointHistory:
    """Where each joint was at each reading and how it got there: ``q_mm`` (n, 3)
    as commanded, ``side`` (n, 3) the direction of its last move (0: unknown),
    ``travel_mm`` (n, 3) the travel since its last reversal (inf: unknown, taken as
    long), ``t_s`` (n,); and the same at each gauge's setting pose (G, 3)."""

    q_mm: np.ndarray
    side: np.ndarray
    travel_mm: np.ndarray
    t_s: np.ndarray
    setting_q_mm: np.ndarray
    setting_side: np.ndarray
    setting_travel_mm: np.ndarray

    @classmethod
    def of(cls, layout: ReadingsLayout) -> JointHistory:
        side = np.asarray(layout.lost_motion_side, dtype=int)
        travel = travel_since_reversal(layout.q_mm, side)
        # a gauge is set at its first reading's pose (ReadingsLayout.build), and its
        # history there is that reading's
        first = np.full(layout.n_gauges, -1)
        order = np.arange(len(layout))[::-1]
        first[layout.gauge[order]] = order
        known = first >= 0
        set_side = np.zeros((layout.n_gauges, 3), dtype=int)
        set_travel = np.full((layout.n_gauges, 3), np.inf)
        set_side[known] = side[first[known]]
        set_travel[known] = travel[first[known]]
        return cls(layout.q_mm, side, travel, layout.t_s, layout.setting_q_mm, set_side,
                   set_travel)


def travel_since_reversal(q_mm: np.ndarray, side: np.ndarray,
                          overshoot_mm: float = DEFAULT_OVERSHOOT_MM) -> np.ndarray:
    """(n, 3) how far each joint has travelled since it last reversed, at each reading
    in the recorded order. A joint that arrives against the direction of its move
    from the last reading (an approach from below or above, ``side`` recorded by the
    plan) reversed ``overshoot_mm`` before the reading; one whose side changed without
    a move went out and back by as much. Before its first known side: inf (unknown)."""
    q = np.asarray(q_mm, dtype=float).reshape(-1, 3)
    side = np.asarray(side, dtype=int).reshape(-1, 3)
    n = len(q)
    if n == 0:
        return np.zeros((0, 3))
    move = np.zeros((n, 3))
    move[1:] = np.diff(q, axis=0)
    length = np.abs(move)
    direction = np.sign(np.round(move, 9)).astype(int)
    previous = np.vstack([side[:1], side[:-1]])  # the first reading is no reversal
    hidden = ((direction != 0) & (direction != side)) | ((direction == 0) & (side != previous))
    reversed_here = (side != previous) & ~hidden
    reset = hidden | reversed_here
    # travel added at each reading; at a reset the travel starts again from what it holds
    start = np.where(hidden, overshoot_mm, length)
    rows = np.arange(n)[:, None]
    last_reset = np.maximum.accumulate(np.where(reset, rows, 0), axis=0)
    cum = np.cumsum(length, axis=0)
    since = cum - np.take_along_axis(cum, last_reset, axis=0) + \
        np.take_along_axis(start, last_reset, axis=0)
    # unknown: no side yet, or a side known from the first reading on (a session's)
    # with no reversal seen since
    seen_reset = np.maximum.accumulate(reset, axis=0)
    return np.where((side != 0) & seen_reset, since, np.inf)


@dataclass(frozen=True)
class ShapeSpread:
    """A term's shape parameter (a pitch) as known: its std, and how the term's
    coefficients move along its profile per unit of it (``path``: they are refitted as
    it moves, so a pitch's error turns the phase about where the readings are, not about
    the reference; None: taken as still)."""

    std: float
    path: np.ndarray | None = None

    def scaled(self, factor: float) -> ShapeSpread:
        return ShapeSpread(self.std * factor, self.path)


NO_SPREAD = ShapeSpread(math.nan)


def tabulation_step(terms: list[MapTerm], scan_step_mm: float | None) -> float:
    """A table's step that represents the terms by linear interpolation: the scan's
    step or 1 mm, finer where a family's shape asks (``MapFamily.table_step_mm``: a
    cyclic error's)."""
    return min(scan_step_mm or 1.0, 1.0, *(t.kind.table_step_mm(t) for t in terms))


def axis_map(terms: list[MapTerm], coefficients: list[np.ndarray], covariance: np.ndarray,
             from_mm: float, to_mm: float, step_mm: float, *, source: str,
             excludes: tuple[str, ...] = (), extra: Mapping | None = None,
             spreads: list[ShapeSpread] | None = None,
             zero_at: float | None = None) -> AxisMap:
    """The ``AxisMap`` of one axis from its fitted along-the-line terms: the band
    (k = 1) from the stacked ``covariance`` and each term's shape spread (a pitch's
    phase slips the farther from where the readings hold it). Forward moving up after a long run,
    reverse moving down (a hysteresis wound up: a controller's backlash table; its
    build-up in ``extra``). ``zero_at``: the reference (the terms' by default); the
    map less its value there forward, the band that of the difference."""
    assert terms and all(t.along and t.axis == terms[0].axis for t in terms)
    # a grid through the reference (where the map is zero), ends added
    ref = terms[0].reference_mm if zero_at is None else zero_at
    first = math.ceil((from_mm - ref) / step_mm - 1e-9)
    last = math.floor((to_mm - ref) / step_mm + 1e-9)
    q = ref + step_mm * np.arange(first, last + 1)
    q = np.unique(np.round(np.concatenate([[from_mm], q, [to_mm]]), 9))

    def shapes(at: np.ndarray, side: int) -> np.ndarray:
        n = len(at)
        return np.vstack([t.shape_of(at, np.full(n, side), np.full(n, np.inf), np.zeros(n))
                          for t in terms])

    at_ref = shapes(np.array([ref]), 1)  # (k, 1)

    def design(side: int) -> np.ndarray:
        return shapes(q, side) - at_ref

    coef = np.concatenate(coefficients)
    designs = {side: design(side) for side in (1, -1)}  # (k, Q) each
    starts = np.cumsum([0] + [len(c) for c in coefficients])
    slip = np.zeros(len(q))  # variance from the shapes' own uncertainty
    for k, (term, c, spread) in enumerate(zip(terms, coefficients,
                                              spreads or [NO_SPREAD] * len(terms),
                                              strict=True)):
        slope_q = term.kind.shape_slope(term, c, q)
        slope_ref = term.kind.shape_slope(term, c, np.array([ref]))
        if slope_q is None or slope_ref is None or not math.isfinite(spread.std):
            continue
        moved = slope_q - slope_ref
        if spread.path is not None:  # the coefficients refitted along the profile
            moved = moved + spread.path @ designs[1][starts[k]:starts[k + 1]]
        slip += (moved * spread.std) ** 2
    out = {}
    for side, g in designs.items():
        values = coef @ g
        var = np.einsum("kq,kl,lq->q", g, covariance, g) + slip
        var += _chord_variance(q, values, coef @ (shapes(0.5 * (q[1:] + q[:-1]), side) - at_ref))
        out[side] = (values, np.sqrt(np.maximum(var, 0.0)))
    return AxisMap(axis=AXES[terms[0].axis], positions_mm=tuple(q.tolist()),
                   forward_mm=tuple(out[1][0].tolist()), reverse_mm=tuple(out[-1][0].tolist()),
                   u_forward_mm=tuple(out[1][1].tolist()),
                   u_reverse_mm=tuple(out[-1][1].tolist()),
                   reference_mm=ref, source=source, excludes=excludes,
                   extra=dict(extra or {}))


def _chord_variance(q: np.ndarray, values: np.ndarray, at_middles: np.ndarray) -> np.ndarray:
    """(Q,) what the map's own grid leaves of its terms, as a variance at each point:
    linear between its points, it misses the terms by the most at a middle; the larger
    of the two middles beside a point, taken as the bound of a rectangular
    distribution (a / sqrt(3), JCGM 100:2008 4.3.7). Beside the reference, where the
    band is nothing, a 6 µm lead's 1.2 % chord was the whole error."""
    if len(q) < 2:
        return np.zeros(len(q))
    gap = np.abs(at_middles - 0.5 * (values[1:] + values[:-1]))
    bound = np.maximum(np.concatenate([gap, [0.0]]), np.concatenate([[0.0], gap]))
    return bound**2 / 3.0


# --- a map's terms, kept beside its table --------------------------------------------

# The shape parameters that are positions along q: they move with the coordinate.
POSITION_SHAPES = ("from_mm", "to_mm")


def terms_json(terms: list[MapTerm]) -> list[dict]:
    """The terms a table was made from, as its ``extra["terms"]`` holds them: a later
    campaign refits what is left of them (``ogacq.calibration.validate``)."""
    return [{"family": t.family, "shape": {k: float(v) for k, v in t.shape.items()},
             "reference_mm": float(t.reference_mm)} for t in terms]


def moved_terms_json(entries: list[dict], by_mm: float) -> list[dict]:
    """``terms_json`` entries in a coordinate moved by ``by_mm`` (``AxisMap.moved``)."""
    return [{**e, "reference_mm": float(e["reference_mm"]) + by_mm,
             "shape": {k: float(v) + by_mm if k in POSITION_SHAPES else float(v)
                       for k, v in e["shape"].items()}} for e in entries]


def terms_of(m: AxisMap) -> list[MapTerm]:
    """The along-the-line terms ``m`` was made from (none when its ``extra`` does not
    say: a library effect's map, a map written by hand)."""
    out = []
    for e in m.extra.get("terms") or ():
        try:
            term = MapTerm(str(e["family"]), AXES.index(m.axis),
                           {str(k): float(v) for k, v in e["shape"].items()},
                           float(e["reference_mm"]))
        except (KeyError, TypeError, ValueError):
            return []  # not terms this version can rebuild: none, rather than some
        if term.along:
            out.append(term)
    return out
