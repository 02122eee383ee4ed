"""``lead_screw_cyclic``: the screw's periodic error, ``A sin(2 pi q / P + phase)``, one
revolution of the screw being its period P (the lead) or a harmonic of it; its pitch
found by the periodogram (``ogacq/diagnose/mapsearch.py``)."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from ogacq.model.families.base import MapFamily, MapTerm, MapValue
from ogacq.model.units import json_number


@dataclass(frozen=True)
class CyclicShape:
    pitch_mm: float


class Cyclic(MapFamily[CyclicShape]):
    name = "lead_screw_cyclic"
    Shape = CyclicShape
    words = "cyclic lead-screw error"
    # no source: orders of magnitude beyond the worst rolled screws' lead error, about
    # 0.2 mm per 300 mm (as for every family's plausible size)
    plausible_mm = 0.1
    periodic = True

    def shape_of(self, term: MapTerm, q: np.ndarray, side: np.ndarray, travel: np.ndarray,
                 t_s: np.ndarray) -> np.ndarray:
        w = 2 * np.pi / self.params(term).pitch_mm
        delta = q - term.reference_mm
        return np.array([np.sin(w * delta), np.cos(w * delta) - 1.0])

    def size(self, term: MapTerm) -> int:
        return 2  # a sine and a cosine: the amplitude and the phase

    def shape_parameters(self, term: MapTerm) -> int:
        return 1

    def size_mm(self, term: MapTerm, coefficients: np.ndarray) -> float:
        return float(np.hypot(coefficients[0], coefficients[1]))

    def value(self, term: MapTerm, coef: np.ndarray, cov: np.ndarray,
              shape_std: float) -> MapValue:
        a, b = float(coef[0]), float(coef[1])
        amp = math.hypot(a, b)
        grad = np.array([a, b]) / max(amp, 1e-300)
        amp_std = float(math.sqrt(max(grad @ cov @ grad, 0.0)))
        phase = math.atan2(b, a)
        gphase = np.array([-b, a]) / max(amp**2, 1e-300)
        phase_std = float(math.sqrt(max(gphase @ cov @ gphase, 0.0)))
        return MapValue(amp, amp_std, {
            "pitch_mm": round(self.params(term).pitch_mm, 6),
            "pitch_std_mm": json_number(shape_std, 6),
            "phase_deg": round(math.degrees(phase), 3),
            "phase_std_deg": json_number(math.degrees(phase_std), 6)})

    def sentence(self, term: MapTerm, value: MapValue) -> str:
        return f"{self.words} of pitch {self.params(term).pitch_mm:.4g} mm"

    def detail(self, extra: Mapping[str, Any]) -> str:
        return (f"pitch {extra['pitch_mm']:.4g} ± {extra.get('pitch_std_mm', 0):.2g} mm, "
                f"phase {extra['phase_deg']:+.1f} ± {extra.get('phase_std_deg', 0):.1f}°")

    def source(self, term: MapTerm) -> str:
        return f"cyclic lead-screw error, pitch {self.params(term).pitch_mm:.3f} mm"

    def table_extra(self, term: MapTerm) -> dict:
        return {"pitch_mm": round(self.params(term).pitch_mm, 6)}

    def table_step_mm(self, term: MapTerm) -> float:
        # 20 points per period: the chord misses a sine by 1.2 % of its amplitude,
        # 1 - cos(pi / 20)
        return self.params(term).pitch_mm / 20.0

    def shape_slope(self, term: MapTerm, coefficients: np.ndarray,
                    q: np.ndarray) -> np.ndarray:
        # a pitch's error slips the phase the farther from the reference
        pitch = self.params(term).pitch_mm
        w = 2 * np.pi / pitch
        delta = q - term.reference_mm
        c = coefficients
        return (c[0] * np.cos(w * delta) - c[1] * np.sin(w * delta)) * delta * (-w / pitch)
