"""An error map of one actuator: the value the diagnosis hands to the compensation.

Every compensation table (LinuxCNC, Fanuc, Siemens, the plain CSV) and ogacq's own
correction of its targets is made from this one type, so sign and reference are
fixed here once:

* ``forward_mm[k]`` is the error ``e+(q_k)`` = actual minus commanded joint position
  at ``q_k`` (controller coordinate, MODEL.md) approached moving toward +q;
  ``reverse_mm[k]`` toward -q. A backlash b shows as ``e+ - e- = -b``.
* A controller that corrects the map commands ``q - e(q)`` (to first order).
* The map is zero at ``reference_mm`` forward: its constant is the joint offset's
  (never twice). ``excludes`` names the parameters the map is orthogonal to.
* ``u_forward_mm``, ``u_reverse_mm``: standard uncertainties (k = 1) per point; a
  table writer multiplies by its k.
* ``q`` is the coordinate of the joint offsets in force when the map was identified:
  an offset written moves it along the screw (``q = p - o``, the screw's errors stay
  at ``p``), so with new offsets the map is ``moved`` (``ogacq.calibration.compensate``).

Between positions the map is linear (as LinuxCNC's and Siemens' tables
interpolate); outside them it holds its end values."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ogacq.errors import InputError
from ogacq.model.gauges import AXES

AXIS_MAP_FORMAT = "ogacq-axis-map/1"


@dataclass(frozen=True)
class AxisMap:
    """The error map of one actuator, forward and reverse (the module's docstring)."""

    axis: str
    positions_mm: tuple[float, ...]
    forward_mm: tuple[float, ...]
    reverse_mm: tuple[float, ...]
    u_forward_mm: tuple[float, ...]
    u_reverse_mm: tuple[float, ...]
    reference_mm: float = 0.0
    # what the map was made from, in words and effect names ("periodic lead screw, pitch
    # 5.00 mm"; "hysteresis"): shown beside every table written from it
    source: str = ""
    excludes: tuple[str, ...] = ()
    extra: Mapping[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        problems = self.problems()
        if problems:
            raise ValueError(f"axis map of {self.axis!r}: {'; '.join(problems)}")

    def problems(self) -> list[str]:
        out = []
        if self.axis not in AXES:
            out.append(f"axis must be one of {', '.join(AXES)}")
        n = len(self.positions_mm)
        if n < 2:
            out.append("at least two positions are needed")
        for name in ("forward_mm", "reverse_mm", "u_forward_mm", "u_reverse_mm"):
            column = getattr(self, name)
            if len(column) != n:
                out.append(f"{name} has {len(column)} values for {n} positions")
            if not all(math.isfinite(v) for v in column):
                out.append(f"{name} holds a value that is not a finite number")
        if not all(math.isfinite(v) for v in self.positions_mm):
            out.append("positions_mm holds a value that is not a finite number")
        elif any(b <= a for a, b in zip(self.positions_mm, self.positions_mm[1:], strict=False)):
            out.append("positions_mm must be strictly ascending")
        if any(u < 0 for u in self.u_forward_mm + self.u_reverse_mm):
            out.append("an uncertainty is negative")
        return out

    def error_mm(self, q_mm: float | np.ndarray, direction: int | np.ndarray) -> np.ndarray:
        """Actual minus commanded joint position at ``q_mm`` approached in ``direction``
        (+1 toward +q, -1 toward -q; 0, an unknown side, gets the mean of both)."""
        q = np.asarray(q_mm, dtype=float)
        d = np.asarray(direction)
        fwd = np.interp(q, self.positions_mm, self.forward_mm)
        rev = np.interp(q, self.positions_mm, self.reverse_mm)
        return np.where(d > 0, fwd, np.where(d < 0, rev, 0.5 * (fwd + rev)))

    def moved(self, by_mm: float) -> AxisMap:
        """The same errors in a controller coordinate moved by ``by_mm``: the joint at
        ``q`` here is at ``q + by_mm`` there (the offset o written lower by ``by_mm``:
        ``q = p - o``). Positions and reference move, the values go with them: nothing
        is interpolated."""
        return AxisMap(self.axis, tuple(q + by_mm for q in self.positions_mm),
                       self.forward_mm, self.reverse_mm, self.u_forward_mm,
                       self.u_reverse_mm, self.reference_mm + by_mm, self.source,
                       self.excludes, self.extra)

    def corrected_target(self, q_mm: float, direction: int) -> float:
        """The target to command so that the joint lands at ``q_mm``: one fixed-point
        step beyond ``q - e(q)``, enough for errors a small fraction of the map's slope
        scale (a map's slope is at most a few um per mm)."""
        first = q_mm - float(self.error_mm(q_mm, direction))
        return q_mm - float(self.error_mm(first, direction))

    def to_json(self) -> dict[str, Any]:
        return {"format": AXIS_MAP_FORMAT, "axis": self.axis,
                "reference_mm": self.reference_mm, "source": self.source,
                "excludes": list(self.excludes),
                "positions_mm": list(self.positions_mm), "forward_mm": list(self.forward_mm),
                "reverse_mm": list(self.reverse_mm), "u_forward_mm": list(self.u_forward_mm),
                "u_reverse_mm": list(self.u_reverse_mm), **({"extra": dict(self.extra)}
                                                           if self.extra else {})}

    @classmethod
    def from_json(cls, data: Mapping[str, Any], where: str = "axis map") -> AxisMap:
        if data.get("format") != AXIS_MAP_FORMAT:
            raise InputError(where, f"not an {AXIS_MAP_FORMAT} map "
                                    f"(format {data.get('format')!r})")
        try:
            return cls(
                axis=str(data["axis"]),
                positions_mm=_floats(data["positions_mm"]),
                forward_mm=_floats(data["forward_mm"]), reverse_mm=_floats(data["reverse_mm"]),
                u_forward_mm=_floats(data["u_forward_mm"]),
                u_reverse_mm=_floats(data["u_reverse_mm"]),
                reference_mm=float(data.get("reference_mm", 0.0)),
                source=str(data.get("source", "")),
                excludes=tuple(str(e) for e in data.get("excludes", ())),
                extra=dict(data.get("extra", {})))
        except KeyError as missing:
            raise InputError(where, f"the map has no {missing.args[0]!r}") from None
        except (TypeError, ValueError) as bad:
            raise InputError(where, str(bad)) from None

    def checksum(self) -> str:
        """SHA-256 of the canonical JSON: the identity a session that applied the map
        records, so that a table changed afterwards is told from the one used."""
        import hashlib  # here: its OpenSSL binding is 3 ms of every diagnosis's start-up
        import json

        canonical = json.dumps(self.to_json(), sort_keys=True, separators=(",", ":"),
                               allow_nan=False)
        return hashlib.sha256(canonical.encode()).hexdigest()


def _floats(values: Sequence[Any]) -> tuple[float, ...]:
    if isinstance(values, str | bytes) or not isinstance(values, Sequence):
        raise TypeError("expected a list of numbers")
    out = []
    for v in values:
        if isinstance(v, bool) or not isinstance(v, int | float):
            raise TypeError(f"{v!r} is not a number")
        out.append(float(v))
    return tuple(out)
