"""A gauge as a traceable instrument: its identity and its calibration certificate.

The campaign file (``[[gauges]]``), the wizard and its inventory give these; the
session header records them (``instruments``); the expired-gauge gate, the
uncertainty budget and the record read them back. Every value may be unknown
(None, or "" for text): a session written before they were recorded reads so.
"""

from __future__ import annotations

import datetime
import math
from collections.abc import Mapping
from dataclasses import dataclass, fields
from typing import Any

from ogacq.io.dates import date_or_none

# The largest expanded uncertainty an indicator's certificate may state: the coarsest
# dial indicator's graduation (0.1 mm, GAUGE_STEP_RANGE_MM in model/machine.py; no
# other source). A larger U is micrometres written as millimetres.
MAX_CERTIFICATE_U_MM = 0.1


@dataclass(frozen=True)
class Instrument:
    gauge: str  # the gauge it served ("y_x")
    make: str | None = None
    model: str | None = None
    serial: str | None = None
    certificate: str | None = None
    calibrated: datetime.date | None = None
    due: datetime.date | None = None
    uncertainty_mm: float | None = None  # the certificate's expanded uncertainty U ...
    uncertainty_k: float | None = None  # ... and its coverage factor k
    resolution_mm: float | None = None  # its display step

    def expired(self, on: datetime.date) -> bool | None:
        """Past its due date on ``on`` (the day after ``due`` is the first day it is
        expired; the due day itself is still within the certificate); None when no
        due date is known."""
        if self.due is None:
            return None
        return _day(on) > self.due

    @property
    def standard_uncertainty_mm(self) -> float | None:
        """The certificate's standard uncertainty u = U / k (JCGM 100:2008 4.3.3:
        an expanded uncertainty quoted with its coverage factor is divided by it);
        None when U or k is unknown."""
        if self.uncertainty_mm is None or not self.uncertainty_k:
            return None
        return self.uncertainty_mm / self.uncertainty_k

    @property
    def label(self) -> str:
        """How messages name it: "y_x (serial 12345678)"."""
        return f"{self.gauge} (serial {self.serial})" if self.serial else self.gauge

    def to_json(self) -> dict[str, Any]:
        """The session header's ``instruments`` entry: every field, dates in ISO form
        (absent values null)."""
        return {f.name: _iso(getattr(self, f.name)) for f in fields(self)}

    @classmethod
    def from_json(cls, entry: Mapping[str, Any]) -> Instrument:
        """An ``instruments`` entry read leniently, each field by its type: a value of
        the wrong kind is unknown."""
        return cls(gauge=str(entry.get("gauge") or ""),
                   **{f.name: _READERS[f.type](entry.get(f.name)) for f in fields(cls)[1:]})


def _day(on: datetime.date) -> datetime.date:
    return on.date() if isinstance(on, datetime.datetime) else on


def _iso(value: Any) -> Any:
    return value.isoformat() if isinstance(value, datetime.date) else value


def _text(value: Any) -> str | None:
    return value if isinstance(value, str) and value else None


def finite_number(value: Any) -> float | None:
    """A JSON number (not a bool) that is finite, as a float; None for anything else."""
    if isinstance(value, bool) or not isinstance(value, int | float):
        return None
    return float(value) if math.isfinite(value) else None


# how ``from_json`` reads a field of each type (the dataclass's annotations, as written)
_READERS: dict[Any, Any] = {"str | None": _text, "datetime.date | None": date_or_none,
                            "float | None": finite_number}
