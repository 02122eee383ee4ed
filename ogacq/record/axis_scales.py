"""The record's ``axis_scales`` section (docs/calibration-record.md section 5): each
axis's ISO 230-2 positioning tests by the scale along its actuator during ``ogacq
calibrate``, declared once (``declared``); built by ``ogacq.record.scale_tests``.

Present only where scales were used: a record without it is the record of a
calibration by the legs' gauges alone.
"""

from __future__ import annotations

from dataclasses import dataclass

from ogacq.record.compensation import Iso230Figures
from ogacq.record.declared import Section
from ogacq.record.sections import InstrumentEntry, SessionFile

__all__ = ["AxisScaleEntry", "ScaleFound", "ScaleTest", "ScaleValidation"]


@dataclass(frozen=True)
class ScaleTest(Section):
    """One positioning test: its session, its targets and runs, its figures (mm)."""

    session: SessionFile
    targets: int
    runs: int
    iso230_2: Iso230Figures


@dataclass(frozen=True)
class ScaleFound(Section):
    """What the test before found along the axis (``ScaleFit``): flat (nothing beyond
    the scale's noise), a cyclic error (its pitch ± std and amplitude), or neither."""

    flat: bool
    pitch_mm: float | None = None
    pitch_std_mm: float | None = None
    amplitude_mm: float | None = None


@dataclass(frozen=True)
class ScaleValidation(Section):
    """The written map judged by the test after (``ScaleCheck``): shown (its deviations
    within the map's U and the test's own at ``within`` of ``targets``, E and A not
    grown), not shown, or worse (and why)."""

    shown: bool
    within: int
    targets: int
    worse: str | None = None


@dataclass(frozen=True)
class AxisScaleEntry(Section):
    """``axis_scales.<axis>``: the scale, its tests before and after the write, what
    it found and how it judged the map (None: no map written on the axis, no test
    after)."""

    instrument: InstrumentEntry
    before: ScaleTest
    found: ScaleFound | None = None
    after: ScaleTest | None = None
    validation: ScaleValidation | None = None
