"""The parameter vocabulary of INTERCHANGE.md as one flat, indexable vector.

Every physical effect the exact model knows is a named entry ``effect.where``
(``joint_offset.x``, ``squareness.xy``, ``gauge_scale.y_x``...). The forward
model always takes the full vector; a fit frees a subset of it. Keeping one
ordering everywhere lets simulation, identification and diagnosis share arrays.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from typing import TypeVar

import numpy as np

from ogacq.model.gauges import AXES, GAUGE_KEYS

T = TypeVar("T")

AXIS_PAIRS = ("xy", "xz", "yz")


@dataclass(frozen=True)
class EffectKind:
    """One kind of model parameter (``squareness``): its unit, where it acts, its
    nominal value and the magnitude beyond which a value is implausible."""

    name: str
    unit: str
    wheres: tuple[str, ...]
    nominal: float
    # Beyond this magnitude a value is implausible for a real machine; a
    # parameter whose std exceeds it cannot be called identified.
    plausible_range: float
    meaning: str


EFFECTS: tuple[EffectKind, ...] = (
    EffectKind("joint_offset", "mm", AXES, 0.0, 10.0, "encoder zero error"),
    EffectKind("leg_length", "mm", AXES, 0.0, 10.0, "leg length minus nominal"),
    EffectKind("squareness", "mrad", AXIS_PAIRS, 0.0, 20.0,
               "90 degrees minus the angle between the two actuator axes"),
    EffectKind("axis_offset", "mm", AXIS_PAIRS, 0.0, 10.0,
               "the two actuator axis lines miss each other by this much"),
    EffectKind("encoder_scale", "ppm", AXES, 0.0, 5000.0, "travel scale error"),
    EffectKind("backlash", "mm", AXES, 0.0, 1.0, "lost motion on reversal"),
    EffectKind("thermal_drift", "mm/h", AXES, 0.0, 1.0, "joint offset drift rate"),
    EffectKind("gauge_position", "fraction", AXES, 0.5, 0.4,
               "where along the leg the gauges were set, from the TCP end"),
    EffectKind("gauge_scale", "ppm", GAUGE_KEYS, 0.0, 50000.0, "gauge gain error"),
)
EFFECT_BY_NAME = {e.name: e for e in EFFECTS}

PARAM_NAMES: tuple[str, ...] = tuple(f"{e.name}.{w}" for e in EFFECTS for w in e.wheres)
PARAM_INDEX: dict[str, int] = {n: k for k, n in enumerate(PARAM_NAMES)}
NOMINAL = np.array([EFFECT_BY_NAME[n.split(".")[0]].nominal for n in PARAM_NAMES])

PARAM_SETS: dict[str, tuple[str, ...]] = {
    "offsets": tuple(f"joint_offset.{a}" for a in AXES),
    "lengths": tuple(f"leg_length.{a}" for a in AXES),
    "both": tuple(f"joint_offset.{a}" for a in AXES) + tuple(f"leg_length.{a}" for a in AXES),
}


def effect_of(name: str) -> EffectKind:
    return EFFECT_BY_NAME[name.split(".")[0]]


def indices(names: Iterable[str]) -> np.ndarray:
    """Positions of the named parameters in the full vector."""
    out = []
    for n in names:
        if n not in PARAM_INDEX:
            raise KeyError(f"unknown parameter {n!r}; known: {', '.join(PARAM_NAMES)}")
        out.append(PARAM_INDEX[n])
    return np.array(out, dtype=int)


def vector(values: Mapping[str, float] | None = None) -> np.ndarray:
    """The full parameter vector: nominal everywhere except the given entries."""
    theta = NOMINAL.copy()
    for name, value in (values or {}).items():
        theta[PARAM_INDEX[name]] = value
    return theta


def nested(names: Iterable[str], values: Iterable[T]) -> dict[str, dict[str, T]]:
    """``{"joint_offset": {"x": ...}}`` as INTERCHANGE.md writes parameters (a value, a
    std that may be None, a result's entry)."""
    out: dict[str, dict[str, T]] = {}
    for name, value in zip(names, values, strict=True):
        effect, where = name.split(".")
        out.setdefault(effect, {})[where] = value
    return out


def non_nominal(theta: np.ndarray, tol: float = 0.0) -> dict[str, float]:
    """The entries of a full vector that differ from nominal."""
    return {n: float(theta[k]) for k, n in enumerate(PARAM_NAMES)
            if abs(theta[k] - NOMINAL[k]) > tol}
