"""Error maps to export in the tests: made by hand here, not by the diagnosis."""

from __future__ import annotations

import numpy as np

from ogacq.model.axis_map import AxisMap


def screw_map(axis: str = "x", *, lo: float = -100.0, hi: float = 60.0, step: float = 2.5,
              amplitude_mm: float = 0.006, pitch_mm: float = 10.0, scale_ppm: float = 150.0,
              lost_mm: float = 0.012, u_mm: float = 0.0008) -> AxisMap:
    """A lead screw's periodic error on a scale error, with lost motion; zero at 0
    forward (the AxisMap's reference), the reverse side b above the forward."""
    q = np.arange(lo, hi + 1e-9, step)
    fwd = amplitude_mm * np.sin(2 * np.pi * q / pitch_mm) + scale_ppm * 1e-6 * q
    rev = fwd + lost_mm
    return AxisMap(axis, tuple(q), tuple(fwd), tuple(rev), tuple(np.full(len(q), u_mm)),
                   tuple(np.full(len(q), 1.5 * u_mm)), source="test screw map")
