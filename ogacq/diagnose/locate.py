"""Where does the misfit sit? Shares per leg, gauge, posture, cycle; trends with time;
differences between approach directions.

A share alone misleads: a gauge with more readings carries more misfit even when
all is noise, and the fit itself takes up some of each group's noise. So every
share is set beside the share pure noise would give it (from the residual-maker
matrix of the fit), and each group's chi-square beside its expected value.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

import numpy as np

from ogacq.identify.consistency import posture_name
from ogacq.identify.distributions import normal_sf
from ogacq.identify.observations import DEVIATION_NAME, POSTURE_OF_SIGN, Observations
from ogacq.model.gauges import Gauge
from ogacq.model.kinematics import nominal_tcp
from ogacq.model.parameters import AXES

LEVELS = ("gauge", "leg", "posture", "cycle", "approach")


@dataclass(frozen=True)
class RowLabels:
    """What each observation belongs to."""

    leg: np.ndarray  # 0..2
    gauge_axis: np.ndarray  # 0..2
    posture: np.ndarray  # "zero", "max", "min", "+30 mm", "max-min"
    cycle: np.ndarray
    t_s: np.ndarray
    approach: np.ndarray  # "+--" per joint, "" when unknown

    @property
    def gauge(self) -> np.ndarray:
        names = np.array([[f"{AXES[j]}_{AXES[i]}" for i in range(3)] for j in range(3)])
        return names[self.gauge_axis, self.leg]

    def cell_codes(self) -> np.ndarray:
        """Each observation's cell (its gauge at its posture) as one integer, equal
        where the cells are: codes rather than names, for a scan's thousands of rows
        (numpy's string functions also cost a command 1.5 ms of import). Their order
        says nothing; a caller lists cells by first reading."""
        postures, posture = np.unique(self.posture.astype(str), return_inverse=True)
        return (self.gauge_axis * 3 + self.leg) * len(postures) + posture.ravel()


def _deviation_name(label: str) -> re.Match[str]:
    found = DEVIATION_NAME.match(label)
    if found is None:  # deviations are read by their names: one that is not cannot be here
        raise ValueError(f"not a deviation's name: {label!r}")
    return found


def row_labels(obs: Observations) -> RowLabels:
    if obs.raw:
        lay = obs.layout
        tcp = np.where(np.isfinite(lay.tcp_mm), lay.tcp_mm,
                       nominal_tcp(lay.q_mm, obs.machine.leg_length_mm))
        along = tcp[np.arange(len(lay)), lay.leg]
        signs = {-1: "-", 0: "0", 1: "+"}
        # named once per distinct value: campaigns repeat few postures many times
        positions, at = np.unique(along, return_inverse=True)
        # each joint's -1/0/+1 as a base-3 digit: one integer per reading, whose
        # distinct values numpy finds far faster than distinct rows
        digits = lay.approach + 1
        sides, side = np.unique(digits[:, 0] * 9 + digits[:, 1] * 3 + digits[:, 2],
                                return_inverse=True)
        return RowLabels(
            lay.leg, lay.gauge_axis,
            np.array([posture_name(s, obs.machine) for s in positions])[at.ravel()],
            lay.cycle, lay.t_s,
            np.array(["".join(signs[int(c) // 3**k % 3 - 1] for k in (2, 1, 0))
                      for c in sides])[side.ravel()])
    parsed = [_deviation_name(label) for label in obs.labels]
    n = len(parsed)
    return RowLabels(
        np.array([AXES.index(m.group(2)) for m in parsed]),
        np.array([AXES.index(m.group(1)) for m in parsed]),
        np.array([POSTURE_OF_SIGN[m.group(3)] for m in parsed]),
        np.ones(n, dtype=int), np.zeros(n), np.full(n, ""))


@dataclass(frozen=True)
class GroupShare:
    level: str
    key: str
    share: float  # of the misfit
    expected_share: float  # under noise alone

    @property
    def excess(self) -> float:
        return self.share - self.expected_share


@dataclass(frozen=True)
class TimeTrend:
    gauge: str
    slope_mm_per_h: float
    std_mm_per_h: float

    @property
    def p_value(self) -> float:
        return float(2 * normal_sf(abs(self.slope_mm_per_h) / self.std_mm_per_h))


@dataclass(frozen=True)
class ApproachDifference:
    gauge: str
    posture: str
    sides: tuple[str, str]
    difference_mm: float  # mean residual of the first side minus the second's
    std_mm: float

    @property
    def p_value(self) -> float:
        return float(2 * normal_sf(abs(self.difference_mm) / self.std_mm))


@dataclass
class Location:
    groups: list[GroupShare]
    trends: list[TimeTrend]
    approach: list[ApproachDifference]

    def level(self, level: str) -> list[GroupShare]:
        return sorted((g for g in self.groups if g.level == level), key=lambda g: -g.share)

    def where(self) -> str:
        """The gauge, leg or posture holding the most misfit beyond its noise share:
        ``y_x`` (a gauge), ``x`` (a leg) or ``min`` (a posture)."""
        pool = [g for g in self.groups if g.level in ("gauge", "leg", "posture")]
        return max(pool, key=lambda g: (g.excess, g.level == "gauge")).key

    def gauges_json(self) -> list[dict]:
        out = []
        for g in self.level("gauge"):
            gauge = Gauge.parse(g.key)
            out.append({"leg": gauge.leg, "gauge_axis": gauge.axis, "share": round(g.share, 4)})
        return out


def residual_variance(obs: Observations, jac: np.ndarray) -> np.ndarray:
    """(m,) variance of each residual of a fit with unweighted Jacobian ``jac`` (m, p)
    under independent noise, in units of the gauge variance: the diagonal of the
    residual maker (gauge zeros and the fitted parameters taken out), for raw
    readings without forming it (campaigns can be long)."""
    if obs.raw:
        gauge = obs.layout.gauge
        projected = obs.remove_zeros(jac.T).T
        u, s, _ = np.linalg.svd(projected, full_matrices=False)
        live = s > (s[0] if len(s) else 0.0) * 1e-10
        leverage = np.sum(u[:, live] ** 2, axis=1)
        return 1.0 - 1.0 / np.bincount(gauge)[gauge] - leverage
    cov = obs.noise_cov
    whitened = np.linalg.solve(np.linalg.cholesky(cov), jac)
    return np.diag(cov - jac @ np.linalg.pinv(whitened.T @ whitened) @ jac.T)


def _scale(obs: Observations) -> np.ndarray:
    """Each observation's own noise variance in units of the gauge variance."""
    return np.ones(len(obs)) if obs.raw else np.diag(obs.noise_cov).copy()


def locate(obs: Observations, residuals: np.ndarray, jac: np.ndarray,
           sigma_mm: float, labels: RowLabels | None = None) -> Location:
    """Where ``residuals`` (unweighted, gauge zeros removed) of a fit with unweighted
    Jacobian ``jac`` sit, judged against the gauge noise ``sigma_mm``. ``labels``:
    ``row_labels(obs)`` when the caller has them."""
    labels = row_labels(obs) if labels is None else labels
    scale = _scale(obs)
    chi2 = residuals**2 / (sigma_mm**2 * scale)
    expected = np.clip(residual_variance(obs, jac) / scale, 0.0, None)
    total, total_expected = float(chi2.sum()), float(expected.sum())
    keys = {"gauge": labels.gauge, "leg": np.array([AXES[i] for i in labels.leg]),
            "posture": labels.posture, "cycle": labels.cycle.astype(str),
            "approach": labels.approach}
    groups = []
    for level in LEVELS:
        distinct, first, which = np.unique(keys[level], return_index=True,
                                           return_inverse=True)
        if len(distinct) < 2:
            continue
        which = which.ravel()
        chi2_sum = np.bincount(which, weights=chi2)
        expected_sum = np.bincount(which, weights=expected)
        for k in np.argsort(first):  # in order of appearance
            groups.append(GroupShare(
                level, str(distinct[k]), float(chi2_sum[k] / total) if total else 0.0,
                float(expected_sum[k] / total_expected) if total_expected else 0.0))
    return Location(groups, _trends(labels, residuals, sigma_mm),
                    _approach_differences(labels, residuals, sigma_mm))


def _trends(labels: RowLabels, residuals: np.ndarray, sigma_mm: float) -> list[TimeTrend]:
    """Slope of each gauge's residuals with time: drift shows here first."""
    out = []
    gauges = labels.gauge
    for g in dict.fromkeys(gauges.tolist()):
        sel = gauges == g
        t_h = labels.t_s[sel] / 3600.0
        spread = np.sum((t_h - t_h.mean()) ** 2)
        if sel.sum() < 3 or spread <= 0:
            continue
        slope = float(np.sum((t_h - t_h.mean()) * residuals[sel]) / spread)
        out.append(TimeTrend(g, slope, float(sigma_mm / np.sqrt(spread))))
    return out


def _approach_differences(labels: RowLabels, residuals: np.ndarray,
                          sigma_mm: float) -> list[ApproachDifference]:
    """Readings of one gauge at one posture approached from different sides: lost
    motion shows as a difference of their means (the two sides read most often at
    that cell, the most read first). Cells and sides are counted with array
    operations: a scan has a thousand cells."""
    gauges = labels.gauge
    cells, first, cell = np.unique(labels.cell_codes(), return_index=True,
                                   return_inverse=True)
    cell = cell.ravel()
    sides, side = np.unique(labels.approach.astype(str), return_inverse=True)
    side = side.ravel()
    n_cells, n_sides = len(cells), len(sides)
    pair = cell * n_sides + side
    count = np.bincount(pair, minlength=n_cells * n_sides).reshape(n_cells, n_sides)
    total = np.bincount(pair, weights=residuals,
                        minlength=n_cells * n_sides).reshape(n_cells, n_sides)
    unknown = np.flatnonzero(sides == "")
    present = count > 0
    eligible = (present.sum(axis=1) >= 2) & (
        ~present[:, unknown].any(axis=1) if len(unknown) else True)
    out: list[ApproachDifference] = []
    # in order of the gauges' first appearance, then of the cells' (as a loop over
    # gauges and their postures would list them)
    gauge_rank = {g: k for k, g in enumerate(dict.fromkeys(gauges.tolist()))}
    candidates = np.flatnonzero(eligible)
    rank = np.array([gauge_rank[g] for g in gauges[first[candidates]].tolist()], dtype=int)
    listed = candidates[np.lexsort((first[candidates], rank))]
    if not len(listed):  # (a single side has no second to rank)
        return out
    # the two sides read most often; among equals, the first in sorted order (one sort
    # of every cell's counts: a dense scan has as many cells as readings)
    ranked = np.argsort(-count[listed], axis=1, kind="stable")[:, :2]
    a, b = ranked[:, 0], ranked[:, 1]
    n_a, n_b = count[listed, a], count[listed, b]
    std = sigma_mm * np.sqrt(1 / n_a + 1 / n_b)
    difference = total[listed, a] / n_a - total[listed, b] / n_b
    for c, side_a, side_b, d, s in zip(listed.tolist(), a.tolist(), b.tolist(),
                                       difference.tolist(), std.tolist(), strict=True):
        out.append(ApproachDifference(
            str(gauges[first[c]]), str(labels.posture[first[c]]),
            (str(sides[side_a]), str(sides[side_b])), d, s))
    return out
