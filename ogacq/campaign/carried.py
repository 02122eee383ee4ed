"""A validation campaign judged with the model that was written (issue 38.4).

A write-back corrects the joint offsets only: what the diagnosis of the calibration
campaign found beside them (a squareness, a leg length) stays on the machine. The
validation campaign after ``offsets write --from-diagnosis`` fitted with the joint
offsets alone is biased by it (offsets of some 0.03 mm, "NOT within the gauge
noise") and reads as a failed write-back. Judged with those effects carried over,
as ``ogacq calibrate`` judges its validation (``ogacq.calibration.validate``), it
shows what the write left: offsets near zero, within the noise.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from ogacq.identify.fit import FitResult, fit
from ogacq.identify.plausibility import check_result
from ogacq.model.parameters import PARAM_SETS
from ogacq.session.convert import session_observations
from ogacq.session.records import OffsetsRecord
from ogacq.session.series import earlier_in_series
from ogacq.session.store import LoadedSession, load_session
from ogacq.writeback.outcome import Stage


@dataclass(frozen=True)
class CarriedFit:
    """The validation's fit with the effects the calibration's diagnosis found."""

    fit: FitResult
    effects: tuple[str, ...]  # carried over beside the joint offsets
    calibration: Path  # the session whose offsets were written

    def describe(self) -> str:
        return (f"judged with the effects the diagnosis of {self.calibration.name} found "
                f"carried over ({', '.join(self.effects)}: a write-back corrects the joint "
                "offsets only, they stay on the machine)")


def validation_of(session: LoadedSession) -> Path | None:
    """The earlier session of the same series whose offsets were written back before
    this one ran: this campaign validates it."""
    for earlier in earlier_in_series(Path(session.path)):
        try:
            loaded = load_session(earlier)
        except Exception:  # an unreadable neighbour is no one's calibration
            continue
        if any(r.stage == Stage.DONE for r in loaded.of_type(OffsetsRecord)):
            return earlier
    return None


def carried_fit(session: LoadedSession) -> CarriedFit | None:
    """The validation ``session`` fitted with the effects the diagnosis of the campaign
    it validates explained its readings with; None when it validates none, or that
    diagnosis needed no effect beside the offsets (or could not be made)."""
    from ogacq.diagnose.diagnosis import DiagnosisError, diagnose

    calibration = validation_of(session)
    if calibration is None:
        return None
    try:
        found = diagnose(session_observations(load_session(calibration)), separate=False)
    except DiagnosisError:
        return None
    if found.outcome != "explained" or not found.effects:
        return None
    effects = tuple(e.name for e in found.effects)
    result = fit(session_observations(session), PARAM_SETS["offsets"] + effects)
    check_result(result)
    return CarriedFit(result, effects, calibration)
