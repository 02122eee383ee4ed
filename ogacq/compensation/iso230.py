"""ISO 230-2 figures of a linear axis from its error map.

ISO 230-2:2014 ("Determination of accuracy and repeatability of positioning of
numerically controlled axes"), clause 3, terms and definitions, as used here
(no copy of the standard's text; the quantities and their formulas):

* positioning deviation x_ij: actual minus target position at target i, approach j
  (the map's sign: ``AxisMap`` errors are actual minus commanded);
* mean unidirectional positioning deviation x̄i↑, x̄i↓ at target i, per approach
  direction; mean bidirectional x̄i = (x̄i↑ + x̄i↓) / 2;
* reversal value Bi = x̄i↑ - x̄i↓; reversal value of the axis B = max |Bi|; mean
  reversal value B̄ = the mean of the Bi;
* estimator of the unidirectional standard uncertainty of positioning si↑, si↓;
* unidirectional repeatability Ri↑ = 4 si↑; bidirectional repeatability at a
  target Ri = max(2 si↑ + 2 si↓ + |Bi|, Ri↑, Ri↓); of the axis R = max Ri
  (R↑, R↓ the maxima of Ri↑, Ri↓);
* unidirectional systematic positioning error E↑ = max x̄i↑ - min x̄i↑;
  bidirectional E = max(x̄i↑, x̄i↓) - min(x̄i↑, x̄i↓);
* mean bidirectional positioning error M = max x̄i - min x̄i;
* unidirectional accuracy A↑ = max(x̄i↑ + 2 si↑) - min(x̄i↑ - 2 si↑);
  bidirectional accuracy A = max(x̄i↑ + 2 si↑, x̄i↓ + 2 si↓)
  - min(x̄i↑ - 2 si↑, x̄i↓ - 2 si↓).

Where the s come from is the caller's to say (``s_source``): here they are the
map's standard uncertainties (k = 1) at each point, the uncertainty of the
identified mean deviation, not the scatter of repeated positioning the standard
measures with a laser: ogacq's gauges read the legs, not the axis, and the
repeats' scatter is the gauges' noise, which the map's u already carries through
the fit. So R here bounds how well the map is known; it is not the machine's
repeatability, and the figures say so.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ogacq.model.axis_map import AxisMap
from ogacq.model.units import UM_PER_MM

MAP_S_SOURCE = "the map's standard uncertainty u (k = 1) at each target, not a repeat scatter"
NAMES = ("A", "A_up", "A_down", "B", "B_mean", "R", "R_up", "R_down", "E", "E_up", "E_down", "M")


@dataclass(frozen=True)
class Iso230Figures:
    axis: str
    targets: int
    from_mm: float
    to_mm: float
    A: float  # noqa: N815 - the standard's names
    A_up: float  # noqa: N815
    A_down: float  # noqa: N815
    B: float  # noqa: N815
    B_mean: float  # noqa: N815
    R: float  # noqa: N815
    R_up: float  # noqa: N815
    R_down: float  # noqa: N815
    E: float  # noqa: N815
    E_up: float  # noqa: N815
    E_down: float  # noqa: N815
    M: float  # noqa: N815
    s_source: str = MAP_S_SOURCE

    def to_json(self) -> dict[str, Any]:
        return {"axis": self.axis, "targets": self.targets,
                "range_mm": [round(self.from_mm, 6), round(self.to_mm, 6)],
                **{f"{n}_mm": round(float(getattr(self, n)), 7) for n in NAMES},
                "s_source": self.s_source, "standard": "ISO 230-2:2014, clause 3"}

    def line(self) -> str:
        """The three figures an operator asks for, in micrometres."""
        um = {n: getattr(self, n) * UM_PER_MM for n in "ABREM"}
        return (f"A {um['A']:.2f} µm, B {um['B']:.2f} µm, R {um['R']:.2f} µm "
                f"(E {um['E']:.2f}, M {um['M']:.2f} µm)")


def iso230_figures(axis: str, targets_mm: np.ndarray, up_mm: np.ndarray, down_mm: np.ndarray,
                   s_up_mm: np.ndarray, s_down_mm: np.ndarray, *,
                   s_source: str = MAP_S_SOURCE) -> Iso230Figures:
    """The figures from the mean deviations and their s at each target."""
    p = np.asarray(targets_mm, float)
    up, down = np.asarray(up_mm, float), np.asarray(down_mm, float)
    su, sd = np.asarray(s_up_mm, float), np.asarray(s_down_mm, float)
    if not (len(p) == len(up) == len(down) == len(su) == len(sd)) or len(p) < 2:
        raise ValueError("ISO 230-2 figures need the same number (two or more) of targets, "
                         "deviations and uncertainties on each side")
    b = up - down
    r_up, r_down = 4 * su, 4 * sd
    r = np.maximum.reduce([2 * su + 2 * sd + np.abs(b), r_up, r_down])
    mean = (up + down) / 2
    both = np.concatenate([up, down])
    return Iso230Figures(
        axis=axis, targets=len(p), from_mm=float(p.min()), to_mm=float(p.max()),
        A=float(max(np.max(up + 2 * su), np.max(down + 2 * sd))
                - min(np.min(up - 2 * su), np.min(down - 2 * sd))),
        A_up=float(np.max(up + 2 * su) - np.min(up - 2 * su)),
        A_down=float(np.max(down + 2 * sd) - np.min(down - 2 * sd)),
        B=float(np.max(np.abs(b))), B_mean=float(np.mean(b)),
        R=float(np.max(r)), R_up=float(np.max(r_up)), R_down=float(np.max(r_down)),
        E=float(both.max() - both.min()), E_up=float(up.max() - up.min()),
        E_down=float(down.max() - down.min()), M=float(mean.max() - mean.min()),
        s_source=s_source)


def map_figures(axis_map: AxisMap, targets_mm: np.ndarray | None = None, *,
                s_source: str = MAP_S_SOURCE) -> Iso230Figures:
    """The figures of the axis the map describes, at ``targets_mm`` (default: the map's
    own positions), its u as the s."""
    p = np.asarray(axis_map.positions_mm if targets_mm is None else targets_mm, float)
    pos = axis_map.positions_mm
    return iso230_figures(
        axis_map.axis, p, axis_map.error_mm(p, 1), axis_map.error_mm(p, -1),
        np.interp(p, pos, axis_map.u_forward_mm), np.interp(p, pos, axis_map.u_reverse_mm),
        s_source=s_source)
