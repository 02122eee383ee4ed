"""What an error-map family is, the term of one on one axis, and the registry.

A family (``MapFamily``) declares everything the tool does with it: its typed shape
parameters, its displacement per unit amplitude (``shape_of``), the shapes its search
tries on an axis (``search``), the largest size a machine in service could show
(``plausible_mm``), its headline value and further parameters, its words in a
sentence, a table's source and the terminal, and, where it has one, what a table's
step and band owe to its shape. ``MapTerm`` is one family on one axis with its shape
fixed, the family found by its name in ``FAMILIES`` (the name is the public key of
the diagnosis JSON and of a table's ``extra["terms"]``). A family defined elsewhere (a
plugin, a test) is one module calling :func:`register`, as gauge protocols are
(``ogacq_drivers.indicators.register``).
"""

from __future__ import annotations

import math
import typing
from abc import ABC, abstractmethod
from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from dataclasses import MISSING, dataclass, field, fields, replace
from functools import cache
from typing import TYPE_CHECKING, Any, ClassVar, Generic, TypeVar

import numpy as np

from ogacq.model.gauges import AXES
from ogacq.model.units import UM_PER_MM

if TYPE_CHECKING:
    from ogacq.model.error_maps import JointHistory

S = TypeVar("S")


@dataclass(frozen=True)
class MapValue:
    """A term's headline value with its std (mm), and its further parameters."""

    value: float
    std: float
    extra: dict


@dataclass(frozen=True)
class SearchedAxis:
    """One axis as a campaign read it: what a family's shapes to try are drawn from."""

    axis: int
    positions: int
    from_mm: float
    to_mm: float
    both_sides: bool
    shortest_travel_mm: float  # after a reversal (inf: never reversed)
    longest_travel_mm: float  # the longest finite travel after a reversal (0: none)
    duration_s: float  # the campaign's, first reading to last
    fitted: tuple[str, ...]  # the library's parameters in the model beside the maps


@dataclass(frozen=True)
class ShapeGrid:
    """The shapes of one candidate tried on an axis (the Bonferroni factor is their
    count): the best by gain, or by the BIC with each shape's rank (``by_bic``: the
    shapes differ in their number of amplitudes); ``refine`` names the shape parameter
    refined between the best one's neighbours (on a log scale, with its std) once the
    candidate is taken; ``of_q_alone``: its shapes depend on the position alone, so a
    dense scan's may be weighed first on the positions' binned sums."""

    terms: tuple[MapTerm, ...]
    by_bic: bool = False
    refine: str | None = None
    of_q_alone: bool = False


class MapFamily(ABC, Generic[S]):
    """One family of errors along an axis or in time. ``Shape``: the frozen dataclass
    of its shape parameters (int, float or bool fields), read from a term's ``shape``
    mapping, whose JSON form (floats) stays the public one."""

    name: ClassVar[str]
    Shape: ClassVar[type]
    words: ClassVar[str]  # what it is, in a sentence
    plausible_mm: ClassVar[float]  # beyond this size no machine in service shows it
    along: ClassVar[bool] = True  # moves the joint along its own line
    tabulated: ClassVar[bool] = True  # an along-the-line error a table holds (not time)
    in_time: ClassVar[bool] = False  # searched where postures were read again later
    # its columns constant over every repeat group (a shape of q and the side); None:
    # it depends on the readings (checked on the columns)
    grouped: ClassVar[bool | None] = True
    periodic: ClassVar[bool] = False  # its shape searched by the periodogram (pitch_mm)
    pointwise: ClassVar[bool] = False  # its amplitudes are values along q, not a size

    def params(self, term: MapTerm) -> S:
        return typing.cast(S, term.params)

    @abstractmethod
    def shape_of(self, term: MapTerm, q: np.ndarray, side: np.ndarray, travel: np.ndarray,
                 t_s: np.ndarray) -> np.ndarray:
        """(k, n) the displacement per unit amplitude (``MapTerm.shape_of``)."""

    def size(self, term: MapTerm) -> int:
        """Its number of amplitudes."""
        return 1

    def shape_parameters(self, term: MapTerm) -> int:
        """Its shape parameters estimated from the readings (a pitch, a build-up
        length, a time constant): degrees of freedom a fit spends beside its
        amplitudes."""
        return 0

    def where(self, term: MapTerm) -> str:
        return AXES[term.axis]

    def sensitivities(self, term: MapTerm, sensitivity: Any,
                      along: tuple[np.ndarray, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
        """(n,) each: the readings' sensitivity to its displacement at their poses and
        at their gauges' setting poses (``JointSensitivity``: along the joint's line)."""
        return along[0][:, term.axis], along[1][:, term.axis]

    def size_mm(self, term: MapTerm, coefficients: np.ndarray) -> float:
        """The largest displacement it makes over its axis's range (both sides)."""
        return float(abs(coefficients[0]))

    def value(self, term: MapTerm, coef: np.ndarray, cov: np.ndarray,
              shape_std: float) -> MapValue:
        """Its headline value with its std, and its further parameters (the
        diagnosis JSON's keys beside ``value``)."""
        return MapValue(float(coef[0]), float(math.sqrt(max(cov[0, 0], 0.0))),
                        self.value_extra(term, shape_std))

    def value_extra(self, term: MapTerm, shape_std: float) -> dict:
        return {}

    @abstractmethod
    def sentence(self, term: MapTerm, value: MapValue) -> str:
        """What it is in the located sentence ("cyclic lead-screw error of pitch 5 mm")."""

    def size_words(self, value: MapValue) -> str:
        return f"about {abs(value.value) * UM_PER_MM:.2g} µm"

    def detail(self, extra: Mapping[str, Any]) -> str:
        """Its further parameters on the terminal (``extra``: its value's, the
        missing ones dropped), before the test's p."""
        return ""

    def source(self, term: MapTerm) -> str:
        """A table's source, in words (a tabulated family)."""
        return self.words

    def table_extra(self, term: MapTerm) -> dict:
        """What a table made of it keeps in its ``extra`` beside the terms."""
        return {}

    def table_step_mm(self, term: MapTerm) -> float:
        """The largest step of a table that represents it by linear interpolation."""
        return math.inf

    def shape_slope(self, term: MapTerm, coefficients: np.ndarray,
                    q: np.ndarray) -> np.ndarray | None:
        """(n,) the displacement's derivative by its shape parameter at ``q`` (a table's
        band widened by the shape's std), None when the band leaves it out."""
        return None

    def in_place_of(self, term: MapTerm, effect: str) -> MapTerm:
        """The term as it stands in for the library's ``effect`` (a part it leaves to
        that effect when both are fitted taken back)."""
        return term

    def swap_terms(self, axis: int, from_mm: float, to_mm: float,
                   fitted: tuple[str, ...]) -> list[MapTerm]:
        """The terms fitted on an axis read over ``from_mm..to_mm`` whatever the
        campaign, weighed as the alternatives of the library's effects (none: [])."""
        return []

    def search(self, axis: SearchedAxis) -> list[ShapeGrid]:
        """The candidates to try on ``axis``, each a grid of shapes (none: []). A
        periodic family's pitch is searched by the periodogram instead."""
        return []


# --- one family on one axis -----------------------------------------------------------

@dataclass(frozen=True)
class MapTerm:
    """One family on one axis with its shape fixed: linear in its amplitudes.
    ``shape`` holds the family's shape parameters as its JSON form has them (floats),
    ``params`` the same typed by the family (``MapFamily.Shape``, in its module)."""

    family: str
    axis: int
    shape: Mapping[str, float] = field(default_factory=dict)
    reference_mm: float = 0.0
    params: Any = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "params", typed_shape(self.kind, self.shape))

    @property
    def kind(self) -> MapFamily:
        """The family's registry entry."""
        try:
            return FAMILIES[self.family]
        except KeyError:
            raise ValueError(f"unknown error-map family {self.family!r}") from None

    @property
    def along(self) -> bool:
        """Moves the joint along its own line (what an axis map compensates)."""
        return self.kind.along

    @property
    def tabulated(self) -> bool:
        """An along-the-line error a table holds (a time one is not)."""
        return self.kind.tabulated

    @property
    def where(self) -> str:
        return self.kind.where(self)

    @property
    def name(self) -> str:
        return f"{self.family}.{self.where}"

    def shape_of(self, q: np.ndarray, side: np.ndarray, travel: np.ndarray,
                 t_s: np.ndarray) -> np.ndarray:
        """(k, n) the displacement per unit amplitude at joint coordinates ``q`` (n,),
        sides ``side``, travels since reversal ``travel`` and times ``t_s``; zero at
        the reference approached forward (along-the-line families)."""
        return self.kind.shape_of(self, np.asarray(q, dtype=float), side, travel, t_s)

    def reshaped(self, **shape: float) -> MapTerm:
        """This term with the shape parameters given changed."""
        return replace(self, shape={**self.shape, **shape})

    def columns(self, history: JointHistory, rows: np.ndarray | slice = slice(None),
                ) -> tuple[np.ndarray, np.ndarray]:
        """(k, n) at the poses of the readings at ``rows`` (all by default) and (k, G) at
        each gauge's setting pose."""
        a = self.axis
        at_reading = self.shape_of(history.q_mm[rows, a], history.side[rows, a],
                                   history.travel_mm[rows, a], history.t_s[rows])
        at_setting = self.shape_of(history.setting_q_mm[:, a], history.setting_side[:, a],
                                   history.setting_travel_mm[:, a],
                                   np.zeros(len(history.setting_q_mm)))
        return at_reading, at_setting

    @property
    def shape_parameters(self) -> int:
        return self.kind.shape_parameters(self)

    @property
    def size(self) -> int:
        return self.kind.size(self)

    def size_mm(self, coefficients: np.ndarray) -> float:
        """The largest displacement it makes with these amplitudes over its axis's
        range (both sides): what its plausibility is judged on."""
        return self.kind.size_mm(self, coefficients)


def typed_shape(family: MapFamily, shape: Mapping[str, float]) -> Any:
    """``shape`` as the family's ``Shape``: each field converted to its type, a field
    without a default required (ValueError naming it)."""
    kwargs = {}
    for name, kind, required in _shape_fields(family.Shape):
        if name in shape:
            kwargs[name] = kind(shape[name])
        elif required:
            raise ValueError(f"{family.name}: its shape lacks {name!r}")
    return family.Shape(**kwargs)


@cache
def _shape_fields(cls: type) -> tuple[tuple[str, type, bool], ...]:
    hints = typing.get_type_hints(cls)
    return tuple((f.name, hints[f.name], f.default is MISSING) for f in fields(cls))


# --- the registry -----------------------------------------------------------------------

FAMILIES: dict[str, MapFamily] = {}


def register(family: MapFamily) -> None:
    """Add a family to ``FAMILIES`` (a plugin's, a test's); ValueError for a name taken."""
    if family.name in FAMILIES:
        raise ValueError(f"error-map family {family.name!r} is already registered")
    FAMILIES[family.name] = family


@contextmanager
def registered(family: MapFamily) -> Iterator[MapFamily]:
    """``family`` in ``FAMILIES`` for the duration of the block (every family searched
    counts in the Bonferroni factor: one left registered changes every later search)."""
    register(family)
    try:
        yield family
    finally:
        FAMILIES.pop(family.name, None)
