"""The error-map families, one module each, in one registry (``FAMILIES``): see
``base.py`` for what a family declares. The built-in ones are registered here in the
order the search tries them; a family defined elsewhere calls ``register``."""

from ogacq.model.families.base import (
    FAMILIES,
    MapFamily,
    MapTerm,
    MapValue,
    SearchedAxis,
    ShapeGrid,
    register,
    registered,
)
from ogacq.model.families.cyclic import Cyclic
from ogacq.model.families.hysteresis import Hysteresis
from ogacq.model.families.rail_bow import RailBow
from ogacq.model.families.smooth import Smooth
from ogacq.model.families.warm_up import WarmUp

for _family in (Cyclic(), Smooth(), Hysteresis(), RailBow(), WarmUp()):
    register(_family)

__all__ = ["FAMILIES", "MapFamily", "MapTerm", "MapValue", "SearchedAxis", "ShapeGrid",
           "register", "registered"]
