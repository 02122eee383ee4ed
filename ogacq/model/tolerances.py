"""A machine's acceptance tolerances (the machine file's ``[tolerances]`` table): read
where a machine file states them and where a record judges its deviations, so a
machine without them never builds this class."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from types import MappingProxyType

from ogacq.model.machine import DECISION_RULES


@dataclass(frozen=True)
class Tolerances:
    """Acceptance of the leg-parallelism deviations (docs/calibration-record.md 4):
    every deviation within +/- ``default_mm`` unless ``per_deviation`` names its own
    (``{"dx_y+": 0.015}``); judged by ``decision_rule`` (ILAC-G8:09/2019: a guard
    band w = U, or the simple rule)."""

    default_mm: float | None = None
    per_deviation: Mapping[str, float] = field(default_factory=dict)
    decision_rule: str = "guard-band"

    def __post_init__(self) -> None:
        # read-only, and hashable with the machine that holds it
        object.__setattr__(self, "per_deviation",
                           MappingProxyType(dict(self.per_deviation)))
        if self.decision_rule not in DECISION_RULES:
            raise ValueError(f"decision_rule must be one of {', '.join(DECISION_RULES)}, "
                             f"got {self.decision_rule!r}")

    def __hash__(self) -> int:
        return hash((self.default_mm, tuple(sorted(self.per_deviation.items())),
                     self.decision_rule))

    def __eq__(self, other: object) -> bool:
        return isinstance(other, Tolerances) and (
            self.default_mm, dict(self.per_deviation), self.decision_rule) == (
            other.default_mm, dict(other.per_deviation), other.decision_rule)

    def of(self, deviation: str) -> float | None:
        """The tolerance of one deviation ("dx_y+"), None when none is set."""
        return self.per_deviation.get(deviation, self.default_mm)

    def to_json(self) -> dict:
        out: dict = {"decision_rule": self.decision_rule}
        if self.default_mm is not None:
            out["deviation_mm"] = self.default_mm
        return {**out, **dict(self.per_deviation)}
