"""``warm_up``: a joint offset that settles with time, ``D (1 - exp(-t / tau))`` (the
library's thermal drift is its linear start), its time constant chosen on a grid of
the campaign's duration."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ogacq.model.families.base import MapFamily, MapTerm, MapValue, SearchedAxis, ShapeGrid

WARM_UP_FRACTIONS = (1 / 16, 1 / 8, 1 / 4, 1 / 2, 1.0, 2.0)  # of the campaign's duration


@dataclass(frozen=True)
class WarmUpShape:
    tau_s: float


class WarmUp(MapFamily[WarmUpShape]):
    name = "warm_up"
    Shape = WarmUpShape
    words = "joint offset settling in time"
    plausible_mm = 1.0
    tabulated = False  # a state of the machine in time, no table's
    in_time = True
    grouped = False

    def shape_of(self, term: MapTerm, q: np.ndarray, side: np.ndarray, travel: np.ndarray,
                 t_s: np.ndarray) -> np.ndarray:
        # zero at t = 0: nothing at the gauges' settings yet
        return (1.0 - np.exp(-np.asarray(t_s, dtype=float) / self.params(term).tau_s))[None]

    def shape_parameters(self, term: MapTerm) -> int:
        return 1

    def value_extra(self, term: MapTerm, shape_std: float) -> dict:
        return {"time_constant_s": round(self.params(term).tau_s, 1)}

    def sentence(self, term: MapTerm, value: MapValue) -> str:
        return f"{self.words} (time constant {self.params(term).tau_s:.0f} s)"

    def search(self, axis: SearchedAxis) -> list[ShapeGrid]:
        if axis.duration_s <= 0:
            return []
        return [ShapeGrid(tuple(MapTerm(self.name, axis.axis, {"tau_s": f * axis.duration_s})
                                for f in WARM_UP_FRACTIONS))]
