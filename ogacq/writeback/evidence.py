"""What a finished campaign says about the joint offsets, and how far to trust it.

The identified joint offset ``drho`` is how far the machine is off *given the
controller offsets in force during the campaign*: the model's physical joint
is ``L + q + drho`` with ``q = raw - o`` the controller coordinate, so the
physical joint is ``L + raw - o + drho`` and the offset that cancels ``drho``
is ``o_new = o_campaign - drho``. (Checked against the simulator: after the
write-back a validation campaign identifies offsets near zero.)

The fit verdict is a chi-square test of the offsets fit's residuals against
the gauge noise (the machine file's repeatability, the scatter of repeated
readings, or the display step; never the misfit itself).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

from scipy import stats

from ogacq.campaign import identify_session
from ogacq.identify.fit import FitResult
from ogacq.io.errors import InputError
from ogacq.model.parameters import AXES
from ogacq.session.store import LoadedSession

# A fit whose residuals are this unlikely under the gauge noise alone is called
# inconsistent: the joint-offset model leaves something out.
SIGNIFICANCE = 0.001


@dataclass(frozen=True)
class FitVerdict:
    """Chi-square of the residuals against the gauge noise."""

    chi2: float
    dof: int
    p_value: float
    noise_mm: float
    noise_source: str
    significance: float = SIGNIFICANCE

    @property
    def consistent(self) -> bool:
        return self.p_value >= self.significance

    @property
    def chi2_per_dof(self) -> float:
        return self.chi2 / self.dof if self.dof > 0 else math.nan

    def describe(self) -> str:
        if self.dof <= 0 or not math.isfinite(self.chi2):
            return (f"no degrees of freedom left to judge the fit against the gauge noise "
                    f"({self.dof} dof)")
        verdict = "consistent with" if self.consistent else "inconsistent with"
        return (f"residuals {verdict} the gauge noise {self.noise_mm:.4g} mm "
                f"({self.noise_source}): chi2 {self.chi2:.1f} for {self.dof} dof "
                f"(chi2/dof {self.chi2_per_dof:.2f}, p {self._p_text()})")

    def _p_text(self) -> str:
        return f"= {self.p_value:.3g}" if self.p_value > 0 else "< 1e-300"

    def to_json(self) -> dict:
        judged = self.dof > 0 and math.isfinite(self.chi2)
        return {"chi2": round(self.chi2, 4) if judged else None, "dof": self.dof,
                "chi2_dof": round(self.chi2_per_dof, 4) if judged else None,
                "p_value": self.p_value, "noise_mm": self.noise_mm,
                "noise_source": self.noise_source, "significance": self.significance,
                "consistent": self.consistent}


def fit_verdict(result: FitResult, significance: float = SIGNIFICANCE) -> FitVerdict:
    sigma = result.noise.sigma_mm
    dof = result.dof
    if dof <= 0 or not sigma > 0:
        # no redundancy left to judge the fit by: nothing supports it either
        return FitVerdict(math.nan, dof, 0.0, sigma, result.noise.source, significance)
    chi2 = result.rss / sigma**2
    return FitVerdict(chi2, dof, float(stats.chi2.sf(chi2, dof)), sigma,
                      result.noise.source, significance)


@dataclass(frozen=True)
class Evidence:
    """The identified offsets of one session, with everything that says how reliable
    they are, and the controller offsets they are relative to."""

    session_path: Path
    identified_mm: dict[str, float]  # drho per axis
    std_mm: dict[str, float]  # from the gauge noise; inf where not determined
    verdict: FitVerdict
    identifiable: bool
    identifiability_reasons: list[str]
    converged: bool
    residual_rms_mm: float
    readings: int
    finished: bool  # the campaign ran to its end
    in_force_mm: dict[str, float] | None  # controller offsets during the campaign
    in_force_consistent: bool  # the same offsets at every start (a resume homes again)
    profile: str | None  # controller profile the campaign ran with
    port: str | None

    def to_json(self) -> dict:
        return {"session": str(self.session_path),
                "identified_mm": self.identified_mm,
                "std_mm": {a: (s if math.isfinite(s) else None) for a, s in self.std_mm.items()},
                "verdict": self.verdict.to_json(), "identifiable": self.identifiable,
                "identifiability_reasons": self.identifiability_reasons,
                "converged": self.converged, "residual_rms_mm": self.residual_rms_mm,
                "readings": self.readings, "finished": self.finished,
                "in_force_mm": self.in_force_mm, "profile": self.profile}


def _stations(session: LoadedSession) -> list[dict]:
    """The station of every start of the campaign: the header's, then each resume's."""
    first = session.header.get("station") or {}
    return [first, *session.of_type("station")]


def evidence_from_session(session: LoadedSession,
                          significance: float = SIGNIFICANCE) -> Evidence:
    """Re-identify the joint offsets from the session's raw readings (the readings are
    the record; a stored result is only a copy) and gather the evidence."""
    if not session.readings:
        raise InputError(session.path, "the session holds no readings: nothing was identified")
    result = identify_session(session)
    values = {a: result.value(f"joint_offset.{a}") for a in AXES}
    std = {a: float(result.std[result.names.index(f"joint_offset.{a}")]) for a in AXES}
    std = {a: s if math.isfinite(s) else math.inf for a, s in std.items()}
    stations = _stations(session)
    controllers = [s.get("controller") or {} for s in stations]
    recorded = [c.get("offsets_mm") for c in controllers]
    known = [{a: float(r[a]) for a in AXES} for r in recorded if isinstance(r, dict)]
    in_force = known[0] if known and len(known) == len(recorded) else None
    consistent = all(
        all(abs(k[a] - known[0][a]) < 1e-9 for a in AXES) for k in known[1:]) if known else True
    ident = result.identifiability
    return Evidence(
        session_path=session.path, identified_mm=values, std_mm=std,
        verdict=fit_verdict(result, significance), identifiable=ident.identifiable,
        identifiability_reasons=list(ident.reasons), converged=result.converged,
        residual_rms_mm=result.residual_rms_mm, readings=len(session.readings),
        finished=session.finished, in_force_mm=in_force, in_force_consistent=consistent,
        profile=controllers[0].get("profile"), port=controllers[0].get("port"))
