"""A throwaway error-map family, whole in this one module: its typed shape, its
displacement, the shapes its search tries, its plausible size, its value and words.
Nothing else in the project names it; ``tests/diagnose/test_new_family.py``
registers :data:`FAMILY` and runs it through the simulator, the search, the fit with
maps, the axis's table and the terminal, which shows that adding a family is one
module and its tests.

The physics (made up for the test, no source): the joint steps by the amplitude
where its carriage crosses from one rail segment to the next, at ``at_mm``.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from ogacq.model.families import MapFamily, MapTerm, MapValue, SearchedAxis, ShapeGrid

NAME = "rail_step"
GRID_MM = 5.0  # the joints tried: one every 5 mm of the range


@dataclass(frozen=True)
class StepShape:
    at_mm: float


class RailStep(MapFamily[StepShape]):
    name = NAME
    Shape = StepShape
    words = "step where the rail's segments meet"
    plausible_mm = 0.05

    def shape_of(self, term: MapTerm, q: np.ndarray, side: np.ndarray, travel: np.ndarray,
                 t_s: np.ndarray) -> np.ndarray:
        at = self.params(term).at_mm
        return ((q >= at).astype(float) - float(term.reference_mm >= at))[None]

    def value_extra(self, term: MapTerm, shape_std: float) -> dict:
        return {"at_mm": self.params(term).at_mm}

    def sentence(self, term: MapTerm, value: MapValue) -> str:
        return f"{self.words} at {self.params(term).at_mm:+g} mm"

    def detail(self, extra: Mapping[str, Any]) -> str:
        return f"the joint steps at {extra['at_mm']:+g} mm"

    def search(self, axis: SearchedAxis) -> list[ShapeGrid]:
        inner = np.arange(axis.from_mm + GRID_MM, axis.to_mm - GRID_MM / 2, GRID_MM)
        return [ShapeGrid(tuple(MapTerm(NAME, axis.axis, {"at_mm": float(at)})
                                for at in inner))]


FAMILY = RailStep()
