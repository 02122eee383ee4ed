"""The effect library: every term of the exact measurement model beyond the joint
offsets, as candidate explanations of a misfit, alone and in pairs.

A candidate is a tuple of parameter names of the vocabulary
(``("squareness.xy",)``, ``("backlash.z", "thermal_drift.x")``); the base model
is always the joint offsets, which every calibration identifies.
"""

from __future__ import annotations

from collections.abc import Iterable
from itertools import combinations

from ogacq.model.parameters import EFFECT_BY_NAME, PARAM_NAMES, PARAM_SETS, effect_of

BASE_MODEL: tuple[str, ...] = PARAM_SETS["offsets"]
EFFECT_PARAMETERS: tuple[str, ...] = tuple(n for n in PARAM_NAMES if n not in BASE_MODEL)

Candidate = tuple[str, ...]
EFFECT_NAMES = frozenset(EFFECT_BY_NAME)


def singles(exclude: Iterable[str] = ()) -> list[Candidate]:
    skip = set(exclude)
    return [(n,) for n in EFFECT_PARAMETERS if n not in skip]


def pairs(exclude: Iterable[str] = ()) -> list[Candidate]:
    return list(combinations([n for (n,) in singles(exclude)], 2))


def entry(name: str) -> dict[str, str]:
    """``{"effect": ..., "where": ...}`` as INTERCHANGE.md names an effect."""
    effect, where = name.split(".")
    return {"effect": effect, "where": where}


def unit(name: str) -> str:
    """The unit of an effect of the vocabulary, or of an error map (mm)."""
    return effect_of(name).unit if name.split(".")[0] in EFFECT_NAMES else "mm"


def label(candidate: Candidate) -> str:
    return " + ".join(candidate) if candidate else "joint offsets only"
