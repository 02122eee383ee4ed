"""The station's gauges: two per leg, each named AXIS_LEG ("y_x": along y on the x leg).

A gauge is one value, :class:`Gauge`; its key ``"y_x"`` is how files, sessions and
the parameter names (``gauge_scale.y_x``) spell it, its index pair how the
vectorised model addresses it. Nothing else parses a gauge's name.
"""

from __future__ import annotations

from dataclasses import dataclass

AXES = ("x", "y", "z")


@dataclass(frozen=True)
class Gauge:
    """The gauge measuring along ``axis`` on the ``leg`` leg."""

    axis: str
    leg: str

    def __post_init__(self) -> None:
        if self.axis not in AXES or self.leg not in AXES or self.axis == self.leg:
            raise ValueError(f"no gauge along {self.axis!r} on the {self.leg!r} leg: a gauge "
                             "measures along x, y or z on another leg")

    @classmethod
    def parse(cls, key: str) -> Gauge:
        """``"y_x"`` -> Gauge("y", "x"); anything else is refused naming the gauges."""
        axis, sep, leg = str(key).partition("_")
        if not sep or axis not in AXES or leg not in AXES or axis == leg:
            raise ValueError(f"{key!r} is not a gauge; gauges are {', '.join(GAUGE_KEYS)}")
        return cls(axis, leg)

    @classmethod
    def at(cls, axis_index: int, leg_index: int) -> Gauge:
        return cls(AXES[axis_index], AXES[leg_index])

    @property
    def key(self) -> str:
        return f"{self.axis}_{self.leg}"

    @property
    def indices(self) -> tuple[int, int]:
        """(index of the axis it measures along, index of its leg)."""
        return AXES.index(self.axis), AXES.index(self.leg)

    def __str__(self) -> str:
        return self.key

    def __lt__(self, other: Gauge) -> bool:  # the order of GAUGES: by leg, then axis
        return self.indices[::-1] < other.indices[::-1]


#: Every gauge, leg by leg: x_... first (y_x, z_x), then the y leg's, then the z leg's.
GAUGES: tuple[Gauge, ...] = tuple(Gauge(axis, leg) for leg in AXES for axis in AXES
                                  if axis != leg)
GAUGE_KEYS: tuple[str, ...] = tuple(g.key for g in GAUGES)
#: (gauge axis, leg) index pairs, in the order of GAUGES.
GAUGE_INDICES: tuple[tuple[int, int], ...] = tuple(g.indices for g in GAUGES)
#: Two indicators moved from leg to leg (the papers' station): the gauges each one
#: serves, the first gauge of every leg for the first, the other for the second.
MOVED_INDICATORS: tuple[tuple[str, ...], ...] = (GAUGE_KEYS[0::2], GAUGE_KEYS[1::2])


def gauges_on(legs: str | tuple[str, ...] | list[str]) -> tuple[Gauge, ...]:
    """The gauges of these legs, in the order of GAUGES."""
    return tuple(g for g in GAUGES if g.leg in legs)
