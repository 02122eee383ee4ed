"""An axis's cyclic screw error fitted from its scale's positioning test: a 1-D fit.

The legs' gauges see a joint's error along its line only where the other legs move
it (``ogacq.calibration.sight``), so a screw's pitch and phase identified from them
drift over the rest of the travel (0.4-1.2 % in pitch on the papers' machine: a
LinuxCNC table leaving up to 2 µm of 2.8). The scale reads the joint over the whole
travel, at targets that sample every lead from 2 to 40 mm at four phases
(``ogacq.protocol.positioning``): there the cyclic error is fitted directly,

    deviation(q, direction) = c + s q + b direction / 2
                              + a1 sin(2 pi (q - r) / P) + a2 (cos(2 pi (q - r) / P) - 1)

(the ``lead_screw_cyclic`` family's shape, ``ogacq/model/families/cyclic.py``; ``c``,
``s`` and ``b`` the joint offset's, the encoder scale's and the lost motion's, which
stay the legs' to identify and are nuisances here), to the mean deviation per target
and direction, each with its uncertainty (``PositioningResult.u_mm``: the runs'
pooled scatter and the display step).
The pitch is the best of a periodogram over the band the targets sample (the grid
fine enough that no target's phase moves by more than 0.002 of a period between its
points), refined by Gauss-Newton with its std from the fit's covariance; the term is
kept only where it is significant beside the nuisances alone (its F test at
``LEVEL_MAP``, times the band's independent frequencies, Bonferroni), its pitch not at
the band's edge (unresolved there), and the fit within the scale's noise (the
residual's variance against the runs' scatter, an F test at the verdict's level).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from ogacq.identify.consistency import LEVEL
from ogacq.identify.distributions import f_sf
from ogacq.identify.observations import Observations, readings_observations
from ogacq.model.axis_map import AxisMap
from ogacq.model.error_maps import ShapeSpread, axis_map, tabulation_step, terms_json
from ogacq.model.families import MapTerm
from ogacq.model.measurement import ReadingsLayout
from ogacq.model.parameters import AXES
from ogacq.model.units import UM_PER_MM
from ogacq.protocol.positioning import PositioningResult
from ogacq.protocol.scan_design import PHASE_GRID, UNSTATED_BAND_MM, frequency_grid

FAMILY = "lead_screw_cyclic"
# A map found by one scan's search is held to ten times the verdict's level (as the
# diagnosis holds a map beside a fit within the noise: README, "Errors along each axis").
LEVEL_MAP = LEVEL / 10
NUISANCES = 3  # c, s, b
GAUSS_NEWTON_STEPS = 8


@dataclass(frozen=True)
class ScaleMap:
    """The cyclic error of ``axis`` as its scale measured it."""

    axis: str
    pitch_mm: float
    pitch_std_mm: float
    coefficients: tuple[float, float]  # the family's sine and (cosine - 1) amplitudes
    covariance: tuple[tuple[float, float], tuple[float, float]]
    reference_mm: float
    p_value: float  # the term's F test, Bonferroni-corrected
    fit_p: float  # the fit's residual against the runs' scatter

    @property
    def term(self) -> MapTerm:
        return MapTerm(FAMILY, AXES.index(self.axis), {"pitch_mm": self.pitch_mm},
                       self.reference_mm)

    @property
    def amplitude_mm(self) -> float:
        return math.hypot(*self.coefficients)

    def error_mm(self, q_mm: np.ndarray) -> np.ndarray:
        """The joint's displacement along its line at ``q_mm`` (zero at the reference)."""
        shape = self.term.shape_of(np.asarray(q_mm, float), np.ones(np.size(q_mm)),
                                   np.full(np.size(q_mm), np.inf), np.zeros(np.size(q_mm)))
        return np.asarray(self.coefficients) @ shape

    def over(self, span_mm: tuple[float, float], zero_at_mm: float) -> AxisMap:
        """The map tabulated over ``span_mm``, zero at ``zero_at_mm`` (``axis_map``)."""
        term = self.term
        return axis_map([term], [np.asarray(self.coefficients)], np.asarray(self.covariance),
                        span_mm[0], span_mm[1], tabulation_step([term], None),
                        source=f"{term.kind.source(term)}, by the {self.axis} axis scale",
                        extra={**term.kind.table_extra(term), "terms": terms_json([term]),
                               "measured_by": "axis scale"},
                        spreads=[ShapeSpread(self.pitch_std_mm)], zero_at=zero_at_mm)

    def sentence(self) -> str:
        return (f"the {self.axis} axis scale measures a cyclic error of "
                f"{self.amplitude_mm * UM_PER_MM:.2f} µm at a pitch of {self.pitch_mm:.4f} ± "
                f"{self.pitch_std_mm:.4f} mm (p {self.p_value:.2g}; fit within the scale's "
                f"noise, p {self.fit_p:.2g}): the map of this axis")

    def to_json(self) -> dict[str, Any]:
        return {"axis": self.axis, "family": FAMILY, "pitch_mm": round(self.pitch_mm, 6),
                "pitch_std_mm": round(self.pitch_std_mm, 7),
                "amplitude_mm": round(self.amplitude_mm, 7),
                "coefficients_mm": [round(c, 9) for c in self.coefficients],
                "covariance": [[float(v) for v in row] for row in self.covariance],
                "reference_mm": self.reference_mm, "p": self.p_value, "fit_p": self.fit_p}


@dataclass(frozen=True)
class _Data:
    q: np.ndarray  # (N,) targets, up then down
    side: np.ndarray  # (N,) +1 / -1
    y: np.ndarray  # (N,) mean deviations
    u: float  # standard uncertainty of each
    noise_dof: int  # of the pooled scatter

    def base(self) -> np.ndarray:
        return np.column_stack([np.ones_like(self.q), self.q, self.side / 2.0])

    def cyclic(self, pitch: float) -> np.ndarray:
        w = 2 * np.pi / pitch
        return np.column_stack([np.sin(w * self.q), np.cos(w * self.q) - 1.0])


@dataclass(frozen=True)
class ScaleFit:
    """What the scale says of its axis's errors along the line beyond the legs' own
    (a joint offset, an encoder scale, a lost motion): ``found`` a cyclic error;
    ``flat`` nothing (the nuisances alone within the scale's noise: a map the legs'
    diagnosis claims there is none); neither: something else, left to the diagnosis."""

    axis: str
    found: ScaleMap | None
    flat: bool
    flat_p: float  # the nuisances alone against the scale's noise

    def sentence(self) -> str:
        if self.found is not None:
            return self.found.sentence()
        if self.flat:
            return (f"the {self.axis} axis scale measures no error along the axis beyond a "
                    f"slope and a lost motion (within its noise, p {self.flat_p:.2g}): no "
                    "map on this axis")
        return (f"the {self.axis} axis scale measures an error along the axis that is no "
                "cyclic error: the diagnosis's map stands there")

    def to_json(self) -> dict[str, Any]:
        return {"axis": self.axis, "flat": self.flat, "flat_p": self.flat_p,
                "found": self.found.to_json() if self.found is not None else None}


def fit_scale(result: PositioningResult) -> ScaleFit:
    """The 1-D fit of the test ``result`` (the module's docstring), its reference ``r``
    the campaign's zero."""
    data = _data(result)
    n = len(data.y)
    if data.u <= 0 or n <= NUISANCES + 3:
        return ScaleFit(result.axis, None, False, math.nan)
    base = data.base()
    rss0 = float(np.sum((data.y - base @ np.linalg.lstsq(base, data.y, rcond=None)[0]) ** 2))
    flat_p = float(f_sf(n - NUISANCES, data.noise_dof, (rss0 / (n - NUISANCES)) / data.u**2))
    found = _scale_map(result, data, rss0)
    return ScaleFit(result.axis, found, found is None and flat_p >= LEVEL, flat_p)


def _scale_map(result: PositioningResult, data: _Data, rss0: float) -> ScaleMap | None:
    """The cyclic error the test ``result`` sees on its axis (None: none significant,
    its pitch unresolved, or the fit not within the scale's noise)."""
    targets = np.asarray(result.targets_mm)
    longest = min(UNSTATED_BAND_MM[1], float(np.ptp(targets)))
    freqs = frequency_grid(targets, (UNSTATED_BAND_MM[0], longest), PHASE_GRID)
    best = _periodogram(data, freqs)
    if best in (0, len(freqs) - 1):
        return None  # at the band's edge: the pitch is not resolved
    pitch, cov, coef, rss1 = _refine(data, 1.0 / float(freqs[best]))
    n, k = len(data.y), NUISANCES + 3
    f_term = ((rss0 - rss1) / 3.0) / (rss1 / (n - k))
    independent = max(1.0, float(np.ptp(targets)) * (freqs[-1] - freqs[0]))
    p_term = min(1.0, float(f_sf(3, n - k, f_term)) * independent)
    fit_p = float(f_sf(n - k, data.noise_dof, (rss1 / (n - k)) / data.u**2))
    if p_term >= LEVEL_MAP or fit_p < LEVEL:
        return None
    amplitudes = (float(coef[NUISANCES]), float(coef[NUISANCES + 1]))
    block = cov[NUISANCES:NUISANCES + 2, NUISANCES:NUISANCES + 2]
    covariance = ((float(block[0, 0]), float(block[0, 1])),
                  (float(block[1, 0]), float(block[1, 1])))
    pitch_std = math.sqrt(max(float(cov[-1, -1]), 0.0)) * pitch**2  # from the frequency's
    return ScaleMap(result.axis, pitch, pitch_std, amplitudes, covariance, 0.0, p_term,
                    fit_p)


def _data(result: PositioningResult) -> _Data:
    t = np.asarray(result.targets_mm, float)
    return _Data(np.concatenate([t, t]), np.concatenate([np.ones_like(t), -np.ones_like(t)]),
                 np.concatenate([result.up_mm, result.down_mm]), result.u_mm,
                 result.noise_dof)


def _periodogram(data: _Data, freqs: np.ndarray) -> int:
    """The frequency whose sine and cosine, beside the nuisances, leave the least."""
    q0, _ = np.linalg.qr(data.base())
    r = data.y - q0 @ (q0.T @ data.y)
    phase = 2 * np.pi * np.outer(freqs, data.q)  # (F, N)
    drop = np.empty(len(freqs))
    for k in range(0, len(freqs), 4096):  # in blocks: a (F, N) pair at a time
        s = np.sin(phase[k:k + 4096])
        c = np.cos(phase[k:k + 4096]) - 1.0
        s -= (s @ q0) @ q0.T
        c -= (c @ q0) @ q0.T
        ss, cc, sc = (s * s).sum(1), (c * c).sum(1), (s * c).sum(1)
        sr, cr = s @ r, c @ r
        det = np.maximum(ss * cc - sc**2, 1e-300)
        drop[k:k + 4096] = (cc * sr**2 - 2 * sc * sr * cr + ss * cr**2) / det
    return int(np.argmax(drop))


def _refine(data: _Data, pitch: float) -> tuple[float, np.ndarray, np.ndarray, float]:
    """Gauss-Newton on the frequency from the periodogram's pitch: the pitch, the
    covariance of (nuisances, amplitudes, frequency), the coefficients and the residual
    sum of squares."""
    f = 1.0 / pitch
    for _ in range(GAUSS_NEWTON_STEPS):
        x, coef, j = _linearised(data, f)
        step = np.linalg.lstsq(j, data.y - x @ coef, rcond=None)[0][-1]
        f += float(step)
        if abs(step) * float(np.max(np.abs(data.q))) < 1e-6:  # the phase moved < 1e-6 turn
            break
    x, coef, j = _linearised(data, f)
    rss = float(np.sum((data.y - x @ coef) ** 2))
    cov = np.linalg.pinv(j.T @ j) * data.u**2
    return 1.0 / f, cov, coef, rss


def _linearised(data: _Data, f: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """At the frequency ``f``: the design (the nuisances, the cyclic pair), its least
    squares coefficients, and the design with the derivative in ``f`` beside it."""
    x = np.column_stack([data.base(), data.cyclic(1.0 / f)])
    coef = np.linalg.lstsq(x, data.y, rcond=None)[0]
    a, b = coef[NUISANCES], coef[NUISANCES + 1]
    w = 2 * np.pi * data.q
    return x, coef, np.column_stack([x, w * (a * np.cos(w * f) - b * np.sin(w * f))])


def with_scale_maps(obs: Observations, fits: Mapping[str, ScaleFit]) -> Observations:
    """``obs`` with each joint where the cyclic error its scale found put it (the joint
    at ``q + e(q)`` for a commanded ``q``, its gauges' settings too): a diagnosis of them
    fits what the scales did not measure. Unchanged where no scale found one."""
    found = {AXES.index(a): f.found for a, f in fits.items() if f.found is not None}
    if not found:
        return obs
    lay = obs.layout
    q = np.array(lay.q_mm, dtype=float)
    for k, m in found.items():
        q[:, k] += m.error_mm(q[:, k])
    layout = ReadingsLayout.build(q, lay.leg, lay.gauge_axis, lay.t_s, lay.cycle, lay.tcp_mm,
                                  lay.approach, lay.posture)
    return readings_observations(obs.machine, layout, obs.values, obs.source, obs.averaged,
                                 obs.averaged_sd_mm)
