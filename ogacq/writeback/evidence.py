"""What a finished campaign says about the joint offsets, and how far to trust it.

The identified joint offset ``drho`` is how far the machine is off *given the
controller offsets in force during the campaign*: the model's physical joint
is ``L + q + drho`` with ``q = raw - o`` the controller coordinate, so the
physical joint is ``L + raw - o + drho`` and the offset that cancels ``drho``
is ``o_new = o_campaign - drho``. (Checked against the simulator: after the
write-back a validation campaign identifies offsets near zero.)

The fit verdict is the one consistency test of ``ogacq/identify/consistency.py``,
the same the diagnosis, the report and the CLI state. When the joint offsets
alone are not within the noise but the diagnosis explains the readings with
effects the controller cannot compensate (a squareness, a leg length), the
offsets of the diagnosis's final model can be written instead: they are the
joint offsets with those effects accounted for, and the effects remain, named.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

from ogacq.diagnose.outliers import described_outliers
from ogacq.identify.consistency import Verdict, fit_verdict
from ogacq.identify.fit import FitResult, StopReason
from ogacq.io.errors import InputError
from ogacq.model.parameters import AXES
from ogacq.session.convert import session_observations
from ogacq.session.identification import identify_session
from ogacq.session.offsets_in_force import offsets_in_force, stations
from ogacq.session.store import LoadedSession


@dataclass(frozen=True)
class Evidence:
    """The identified offsets of one session, with everything that says how reliable
    they are, and the controller offsets they are relative to."""

    session_path: Path
    identified_mm: dict[str, float]  # drho per axis
    std_mm: dict[str, float]  # from the gauge noise; inf where not determined
    verdict: Verdict
    identifiable: bool
    identifiability_reasons: list[str]
    fit_stop: StopReason  # why the offsets fit stopped: converged, or not and why
    residual_rms_mm: float
    readings: int
    finished: bool  # the campaign ran to its end
    in_force_mm: dict[str, float] | None  # controller offsets during the campaign
    in_force_consistent: bool  # the same offsets at every start (a resume homes again)
    profile: str | None  # controller profile the campaign ran with
    port: str | None
    model: str = "joint offsets"  # or "diagnosis: ..." naming the effects fitted beside
    # effects of the model the controller cannot compensate: they remain, mechanically
    uncompensated: list[str] = field(default_factory=list)
    # readings far from their repeats, which agree among themselves (a misread, a
    # gauge knocked between cycles): each described, none when there is none
    outliers: list[str] = field(default_factory=list)

    @property
    def converged(self) -> bool:
        return self.fit_stop.converged

    def to_json(self) -> dict:
        return {"session": str(self.session_path),
                "identified_mm": self.identified_mm,
                "std_mm": {a: (s if math.isfinite(s) else None) for a, s in self.std_mm.items()},
                "verdict": self.verdict.to_record(), "identifiable": self.identifiable,
                "identifiability_reasons": self.identifiability_reasons,
                "converged": self.converged, "fit_stop": self.fit_stop.value,
                "residual_rms_mm": self.residual_rms_mm,
                "readings": self.readings, "finished": self.finished,
                "in_force_mm": self.in_force_mm, "profile": self.profile,
                "model": self.model, "uncompensated": self.uncompensated,
                "outliers": self.outliers}


def evidence_from_session(session: LoadedSession, from_diagnosis: bool = False) -> Evidence:
    """Re-identify the joint offsets from the session's raw readings (the readings are
    the record; a stored result is only a copy) and gather the evidence.
    ``from_diagnosis``: the joint offsets of the diagnosis's final model."""
    if not session.readings:
        raise InputError(session.path, "the session holds no readings: nothing was identified")
    model, uncompensated = "joint offsets", []
    if from_diagnosis:
        result, verdict, effects = _diagnosed(session)
        if effects:
            model = "diagnosis: joint offsets with " + ", ".join(effects)
            uncompensated = effects
    else:
        result = identify_session(session)
        verdict = fit_verdict(result)
    return evidence_of(session, result, verdict, model, uncompensated)


def evidence_of(session: LoadedSession, result: FitResult, verdict: Verdict, model: str,
                uncompensated: list[str], shift_mm: dict[str, float] | None = None,
                ) -> Evidence:
    """The evidence of a fit of the session's readings. ``shift_mm``: added to each
    identified joint offset (the constant of a map written beside the offsets, which
    the offset must then carry: ``ogacq.compensation.effects``)."""
    shift = shift_mm or {}
    values = {a: result.value(f"joint_offset.{a}") + shift.get(a, 0.0) for a in AXES}
    std = {a: float(result.std[result.names.index(f"joint_offset.{a}")]) for a in AXES}
    std = {a: s if math.isfinite(s) else math.inf for a, s in std.items()}
    controllers = [s.get("controller") or {} for s in stations(session)]
    in_force = offsets_in_force(session)
    ident = result.identifiability
    return Evidence(
        session_path=session.path, identified_mm=values, std_mm=std,
        verdict=verdict, identifiable=ident.identifiable,
        identifiability_reasons=list(ident.reasons), fit_stop=result.stop_reason,
        residual_rms_mm=result.residual_rms_mm, readings=len(session.readings),
        finished=session.finished, in_force_mm=in_force.offsets_mm,
        in_force_consistent=in_force.consistent,
        # the profile's own name (a profile file is recorded by its path as well)
        profile=controllers[0].get("profile_name") or controllers[0].get("profile"),
        port=controllers[0].get("port"),
        model=model, uncompensated=uncompensated, outliers=described_outliers(result))


def _diagnosed(session: LoadedSession) -> tuple[FitResult, Verdict, list[str]]:
    """The diagnosis's final model: its fit, its verdict and the effects beside the
    joint offsets (none when the offsets alone are within the noise)."""
    from ogacq.diagnose.diagnosis import DiagnosisError, diagnose

    try:
        d = diagnose(session_observations(session), separate=False)
    except DiagnosisError as exc:
        raise InputError(session.path, str(exc)) from None
    return d.final_fit, d.final, [e.name for e in d.effects]
