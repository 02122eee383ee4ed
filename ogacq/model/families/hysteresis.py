"""``hysteresis``: lost motion that builds up with the travel ``s`` since the last
reversal, ``B (1 - exp(-s / length))`` (the first-order law of friction-driven
wind-up, Dahl's model: P. R. Dahl, "A solid friction model", Aerospace Corp.
TOR-0158(3107-18)-1, 1968); its zero-length limit is the library's constant
backlash."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from ogacq.model.families.base import MapFamily, MapTerm, MapValue, SearchedAxis, ShapeGrid
from ogacq.model.units import UM_PER_MM, json_number

# the build-up lengths tried: 0 (a constant backlash) to 32 mm, doubling
BUILD_UP_MM = (0.0, 0.25, 0.5, 1.0, 2.0, 4.0, 8.0, 16.0, 32.0)


@dataclass(frozen=True)
class HysteresisShape:
    length_mm: float


class Hysteresis(MapFamily[HysteresisShape]):
    name = "hysteresis"
    Shape = HysteresisShape
    words = "hysteresis building up with travel"
    plausible_mm = 1.0  # the library's largest backlash
    grouped = None  # a group's readings may follow different travels

    def shape_of(self, term: MapTerm, q: np.ndarray, side: np.ndarray, travel: np.ndarray,
                 t_s: np.ndarray) -> np.ndarray:
        length = self.params(term).length_mm
        side = np.asarray(side, dtype=float)
        with np.errstate(over="ignore"):
            wound = 1.0 if length <= 0 else 1.0 - 2.0 * np.exp(-np.asarray(travel) / length)
        # the joint lags behind its direction of travel; zero when wound forward
        return ((1.0 - side * wound) / 2.0)[None]

    def shape_parameters(self, term: MapTerm) -> int:
        return int(self.params(term).length_mm > 0)

    def value_extra(self, term: MapTerm, shape_std: float) -> dict:
        return {"build_up_mm": round(self.params(term).length_mm, 4),
                "build_up_std_mm": json_number(shape_std, 6)}

    def sentence(self, term: MapTerm, value: MapValue) -> str:
        return f"{self.words} (over {self.params(term).length_mm:.2g} mm)"

    def size_words(self, value: MapValue) -> str:
        return f"lost motion about {abs(value.value) * UM_PER_MM:.2g} µm"

    def detail(self, extra: Mapping[str, Any]) -> str:
        std = extra.get("build_up_std_mm")
        return (f"builds up over {extra['build_up_mm']:.3g}"
                + (f" ± {std:.2g}" if std is not None else "")
                + " mm of travel after a reversal")

    def source(self, term: MapTerm) -> str:
        return f"hysteresis building up over {self.params(term).length_mm:.3g} mm (wound-up values)"

    def table_extra(self, term: MapTerm) -> dict:
        return {"hysteresis_build_up_mm": round(self.params(term).length_mm, 4)}

    def search(self, axis: SearchedAxis) -> list[ShapeGrid]:
        # only where the joint was read from both sides, after a known reversal
        if not axis.both_sides or not math.isfinite(axis.shortest_travel_mm):
            return []
        grid = [b for b in BUILD_UP_MM if b <= axis.longest_travel_mm / 2]
        if not grid:
            return []
        return [ShapeGrid(tuple(MapTerm(self.name, axis.axis, {"length_mm": b}) for b in grid),
                          refine="length_mm")]
