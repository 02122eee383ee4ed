"""``rail_bow``: the rail's straightness, the joint moving across its line by a
parabola over the travel (its constant and linear parts are the library's axis
offsets and squareness)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ogacq.model.families.base import MapFamily, MapTerm, MapValue, SearchedAxis, ShapeGrid
from ogacq.model.gauges import AXES
from ogacq.model.units import UM_PER_MM


@dataclass(frozen=True)
class RailBowShape:
    from_mm: float
    to_mm: float
    toward: int  # the world axis the joint centre moves along


class RailBow(MapFamily[RailBowShape]):
    name = "rail_bow"
    Shape = RailBowShape
    words = "rail bow"
    plausible_mm = 0.5
    along = False
    tabulated = False

    def shape_of(self, term: MapTerm, q: np.ndarray, side: np.ndarray, travel: np.ndarray,
                 t_s: np.ndarray) -> np.ndarray:
        s = self.params(term)
        xi = (2.0 * q - (s.from_mm + s.to_mm)) / (s.to_mm - s.from_mm)
        return (1.0 - xi**2)[None]  # the sagitta: 1 mid-travel, 0 at the ends

    def where(self, term: MapTerm) -> str:
        return AXES[term.axis] + AXES[self.params(term).toward]

    def sensitivities(self, term: MapTerm, sensitivity: Any,
                      along: tuple[np.ndarray, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
        return sensitivity.across(term.axis, self.params(term).toward)

    def value_extra(self, term: MapTerm, shape_std: float) -> dict:
        # the range as the term holds it: the JSON's form (an int stays one)
        return {"toward": AXES[self.params(term).toward], "from_mm": term.shape["from_mm"],
                "to_mm": term.shape["to_mm"]}

    def sentence(self, term: MapTerm, value: MapValue) -> str:
        return f"{self.words} toward {AXES[self.params(term).toward]}"

    def size_words(self, value: MapValue) -> str:
        return f"sagitta about {value.value * UM_PER_MM:+.2g} µm"

    def swap_terms(self, axis: int, from_mm: float, to_mm: float,
                   fitted: tuple[str, ...]) -> list[MapTerm]:
        # toward each of the other two axes
        return [MapTerm(self.name, axis, {"from_mm": from_mm, "to_mm": to_mm, "toward": toward})
                for toward in range(3) if toward != axis]

    def search(self, axis: SearchedAxis) -> list[ShapeGrid]:
        return [ShapeGrid((term,)) for term in
                self.swap_terms(axis.axis, axis.from_mm, axis.to_mm, axis.fitted)]
