"""Errors of an axis beyond the effect library: their shapes along the joint
coordinate ``q``, with the approach side, the travel since the last reversal, and
time.

The effect library (``parameters.py``) describes each joint by constants: an
offset, a travel scale, a lost motion, a drift rate. A real linear axis also has
errors that vary along its travel, which calibration engineers map with a laser
and correct with a compensation table (ISO 230-2:2014 measures them position by
position, in both directions):

* ``lead_screw_cyclic``: the screw's periodic error, ``A sin(2 pi q / P + phase)``,
  one revolution of the screw being its period P (the lead) or a harmonic of it;
* ``screw_map``: a smooth error along the travel (the cumulative lead error of the
  screw, its thermal growth pattern), a cubic spline in ``q``;
* ``hysteresis``: lost motion that builds up with the travel ``s`` since the last
  reversal, ``B (1 - exp(-s / length))`` (the first-order law of friction-driven
  wind-up, Dahl's model: P. R. Dahl, "A solid friction model", Aerospace Corp.
  TOR-0158(3107-18)-1, 1968); its zero-length limit is the library's constant
  backlash;
* ``rail_bow``: the rail's straightness, the joint moving across its line by a
  parabola over the travel (its constant and linear parts are the library's axis
  offsets and squareness);
* ``warm_up``: a joint offset that settles with time, ``D (1 - exp(-t / tau))``
  (the library's thermal drift is its linear start);
* ``leg_growth``: a leg's length that settles likewise.

Each family is linear in its amplitudes once its shape (pitch, knots, build-up
length, time constant) is fixed: :meth:`MapTerm.columns` gives the displacement per
unit of each amplitude for every reading. The diagnosis fits the amplitudes by
least squares and searches the shapes. Every along-the-line term is zero at the
reference position approached in the forward direction (``AxisMap``'s
convention): its constant is the joint offset's.

Sign: a displacement is actual minus commanded joint position, as in ``AxisMap``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np

from ogacq.model.axis_map import AxisMap
from ogacq.model.gauges import AXES
from ogacq.model.measurement import ReadingsLayout

ALONG_FAMILIES = ("lead_screw_cyclic", "screw_map", "hysteresis")
FAMILIES = (*ALONG_FAMILIES, "rail_bow", "warm_up", "leg_growth")
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
    def of(cls, layout: ReadingsLayout, overshoot_mm: float = DEFAULT_OVERSHOOT_MM,
           ) -> JointHistory:
        side = np.asarray(layout.lost_motion_side, dtype=int)
        travel = travel_since_reversal(layout.q_mm, side, overshoot_mm)
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


# --- the families' shapes -----------------------------------------------------------

def cubic_bspline(x: np.ndarray, knots: np.ndarray) -> np.ndarray:
    """(K, n) the cubic B-spline basis on the clamped knot vector (``knots`` the breaks
    from the first to the last, ascending) at ``x``, by the Cox-de Boor recursion
    (C. de Boor, A Practical Guide to Splines, 1978, ch. IX); values outside the
    breaks continue the end polynomials (a table holds its end values anyway)."""
    x = np.asarray(x, dtype=float)
    t = np.concatenate([[knots[0]] * 3, knots, [knots[-1]] * 3])
    # degree 0: the interval each x lies in, the last one closed, ends extended
    k0 = np.clip(np.searchsorted(knots, x, side="right") - 1, 0, len(knots) - 2) + 3
    basis = (np.arange(len(t) - 1)[:, None] == k0[None, :]).astype(float)
    for degree in range(1, 4):
        left_den = t[degree:-1] - t[:-degree - 1]
        right_den = t[degree + 1:] - t[1:-degree]
        with np.errstate(invalid="ignore", divide="ignore"):
            left = np.where(left_den[:, None] > 0,
                            (x[None, :] - t[:-degree - 1, None]) / left_den[:, None], 0.0)
            right = np.where(right_den[:, None] > 0,
                             (t[degree + 1:, None] - x[None, :]) / right_den[:, None], 0.0)
        basis = left * basis[:-1] + right * basis[1:]
    return basis


@dataclass(frozen=True)
class MapTerm:
    """One family on one axis with its shape fixed: linear in its amplitudes.

    ``shape`` holds the family's shape parameters: ``pitch_mm`` (cyclic),
    ``from_mm``/``to_mm``/``knots`` (screw map, rail bow), ``detrended`` (screw map:
    made orthogonal to a slope over its range, which an encoder scale in the model
    carries), ``toward`` (rail bow: the world axis the joint moves along),
    ``length_mm`` (hysteresis), ``tau_s`` (warm-up)."""

    family: str
    axis: int
    shape: Mapping[str, float] = field(default_factory=dict)
    reference_mm: float = 0.0

    def __post_init__(self) -> None:
        if self.family not in FAMILIES:
            raise ValueError(f"unknown error-map family {self.family!r}")

    @property
    def along(self) -> bool:
        """Moves the joint along its own line (what an axis map compensates)."""
        return self.family in ALONG_FAMILIES or self.family == "warm_up"

    @property
    def toward(self) -> int:
        return int(self.shape["toward"])

    @property
    def where(self) -> str:
        if self.family == "rail_bow":
            return AXES[self.axis] + AXES[self.toward]
        return AXES[self.axis]

    @property
    def name(self) -> str:
        return f"{self.family}.{self.where}"

    def _spline_knots(self) -> np.ndarray:
        return np.linspace(self.shape["from_mm"], self.shape["to_mm"],
                           int(self.shape["knots"]) + 2)

    def shape_of(self, q: np.ndarray, side: np.ndarray, travel: np.ndarray,
                 t_s: np.ndarray) -> np.ndarray:
        """(k, n) the displacement per unit amplitude at joint coordinates ``q`` (n,),
        sides ``side``, travels since reversal ``travel`` and times ``t_s``; zero at
        the reference approached forward (along-the-line families)."""
        q = np.asarray(q, dtype=float)
        ref = self.reference_mm
        if self.family == "lead_screw_cyclic":
            w = 2 * np.pi / self.shape["pitch_mm"]
            return np.array([np.sin(w * (q - ref)), np.cos(w * (q - ref)) - 1.0])
        if self.family == "screw_map":
            knots = self._spline_knots()
            basis = cubic_bspline(q, knots) - cubic_bspline(np.array([ref]), knots)
            # the basis sums to one: less one function it spans the rest once
            basis = basis[1:]
            if self.shape.get("detrended"):  # the slope is the encoder scale's
                grid = np.linspace(knots[0], knots[-1], 401) - ref
                on_grid = cubic_bspline(grid + ref, knots)[1:] - \
                    cubic_bspline(np.array([ref]), knots)[1:]
                slope = on_grid @ grid / (grid @ grid)
                basis = basis - slope[:, None] * (q - ref)[None, :]
            return basis
        if self.family == "hysteresis":
            length = self.shape["length_mm"]
            side = np.asarray(side, dtype=float)
            with np.errstate(over="ignore"):
                wound = 1.0 if length <= 0 else 1.0 - 2.0 * np.exp(-np.asarray(travel) / length)
            # the joint lags behind its direction of travel; zero when wound forward
            return ((1.0 - side * wound) / 2.0)[None]
        if self.family == "rail_bow":
            lo, hi = self.shape["from_mm"], self.shape["to_mm"]
            xi = (2.0 * q - (lo + hi)) / (hi - lo)
            return (1.0 - xi**2)[None]  # the sagitta: 1 mid-travel, 0 at the ends
        # warm_up, leg_growth: settling with time
        return (1.0 - np.exp(-np.asarray(t_s, dtype=float) / self.shape["tau_s"]))[None]

    def columns(self, history: JointHistory) -> tuple[np.ndarray, np.ndarray]:
        """(k, n) at each reading's pose and (k, G) at each gauge's setting pose."""
        a = self.axis
        at_reading = self.shape_of(history.q_mm[:, a], history.side[:, a],
                                   history.travel_mm[:, a], history.t_s)
        at_setting = self.shape_of(history.setting_q_mm[:, a], history.setting_side[:, a],
                                   history.setting_travel_mm[:, a],
                                   np.zeros(len(history.setting_q_mm)))
        return at_reading, at_setting

    @property
    def shape_parameters(self) -> int:
        """Its shape parameters estimated from the readings (pitch, build-up length,
        time constant): degrees of freedom the fit spends beside its amplitudes."""
        if self.family in ("lead_screw_cyclic", "warm_up"):
            return 1
        if self.family == "hysteresis":
            return int(self.shape["length_mm"] > 0)
        return 0

    @property
    def size(self) -> int:
        if self.family == "lead_screw_cyclic":
            return 2
        if self.family == "screw_map":
            return int(self.shape["knots"]) + 3
        return 1


def tabulation_step(terms: list[MapTerm], scan_step_mm: float | None) -> float:
    """A table's step that represents the terms by linear interpolation: the scan's
    step or 1 mm, finer for a cyclic error (20 points per period: the chord misses a
    sine by 1.2 % of its amplitude, 1 - cos(pi / 20))."""
    step = min(scan_step_mm or 1.0, 1.0)
    for term in terms:
        if term.family == "lead_screw_cyclic":
            step = min(step, term.shape["pitch_mm"] / 20.0)
    return step


def axis_map(terms: list[MapTerm], coefficients: list[np.ndarray], covariance: np.ndarray,
             from_mm: float, to_mm: float, step_mm: float, *, source: str,
             excludes: tuple[str, ...] = (), extra: Mapping | None = None,
             shape_std: list[float] | None = None, zero_at: float | None = None) -> AxisMap:
    """The ``AxisMap`` of one axis from its fitted along-the-line terms: ``coefficients``
    per term, ``covariance`` of all of them stacked (standard uncertainty per point
    from it, k = 1), ``shape_std`` each term's shape parameter's std (a cyclic error's
    pitch: a phase that slips the farther from the reference, added to the band).
    Forward is the map approached moving up after a long run, reverse moving down (a
    hysteresis at its wound-up value: the table of a controller's backlash
    compensation; how it builds up is in ``extra``). ``zero_at``: the map's reference
    (the terms' when not given): the map less its value there forward, its band that of
    the difference (the constant is the joint offset's, uncertainty included)."""
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
    slip = np.zeros(len(q))  # variance from the shapes' own uncertainty
    for term, c, std in zip(terms, coefficients, shape_std or [math.nan] * len(terms),
                            strict=True):
        if term.family == "lead_screw_cyclic" and math.isfinite(std):
            pitch = term.shape["pitch_mm"]
            w = 2 * np.pi / pitch

            def d_pitch(x: np.ndarray, c: np.ndarray = c, w: float = w,
                        pitch: float = pitch, term: MapTerm = term) -> np.ndarray:
                delta = x - term.reference_mm
                return (c[0] * np.cos(w * delta) - c[1] * np.sin(w * delta)) * delta * (-w / pitch)

            slip += ((d_pitch(q) - d_pitch(np.array([ref]))) * std) ** 2
    out = {}
    for side in (1, -1):
        g = design(side)  # (k, Q)
        values = coef @ g
        var = np.einsum("kq,kl,lq->q", g, covariance, g) + slip
        out[side] = (values, np.sqrt(np.maximum(var, 0.0)))
    return AxisMap(axis=AXES[terms[0].axis], positions_mm=tuple(q.tolist()),
                   forward_mm=tuple(out[1][0].tolist()), reverse_mm=tuple(out[-1][0].tolist()),
                   u_forward_mm=tuple(out[1][1].tolist()),
                   u_reverse_mm=tuple(out[-1][1].tolist()),
                   reference_mm=ref, source=source, excludes=excludes,
                   extra=dict(extra or {}))


def library_axis_maps(values: Mapping[str, float], std: Mapping[str, float],
                      from_mm: float, to_mm: float, step_mm: float = 1.0,
                      ) -> tuple[AxisMap, ...]:
    """The library effects a controller compensates along an axis, as ``AxisMap``:
    ``encoder_scale.a`` (ppm; the error ``q s 1e-6``, zero at q = 0) and
    ``backlash.a`` (mm). The joint offsets stay offsets. A backlash ``b`` puts the
    joint ``b / 2`` short of the target from either side about the offset
    (``measurement.py``); the map is zero forward, ``+b`` reverse, so the joint
    offset that goes with it is ``b / 2`` smaller: ``extra["joint_offset_change_mm"]``
    says by how much (to add to the identified offset when both are compensated)."""
    out = []
    q = np.round(np.arange(from_mm, to_mm + step_mm / 2, step_mm), 9)
    for a in AXES:
        scale = values.get(f"encoder_scale.{a}", 0.0)
        lost = values.get(f"backlash.{a}", 0.0)
        if not scale and not lost:
            continue
        u_scale = std.get(f"encoder_scale.{a}", 0.0) * np.abs(q) * 1e-6
        u_lost = std.get(f"backlash.{a}", 0.0)
        forward = q * scale * 1e-6
        reverse = forward + lost
        sources = [n for n, v in ((f"encoder_scale.{a}", scale), (f"backlash.{a}", lost)) if v]
        out.append(AxisMap(
            axis=a, positions_mm=tuple(q.tolist()), forward_mm=tuple(forward.tolist()),
            reverse_mm=tuple(reverse.tolist()), u_forward_mm=tuple(u_scale.tolist()),
            u_reverse_mm=tuple(np.hypot(u_scale, u_lost).tolist()),
            source="library: " + ", ".join(sources),
            extra={"joint_offset_change_mm": -lost / 2.0} if lost else {}))
    return tuple(out)


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
