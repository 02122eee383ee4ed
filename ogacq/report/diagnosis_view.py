"""The diagnosis JSON of INTERCHANGE.md (``ogacq diagnose --json``), checked and typed
for the report. The report depends on that JSON only, never on the diagnosis code.

Optional keys beyond the contract are shown when present: per effect
``separated_by`` (sentences saying which extra measurement would tell it from its
alternatives) and ``located`` (an error map's place along its axis); top-level
``caveats``, ``maps`` (ogacq-axis-map/1 tables), ``proposals`` (scans that would
separate explanations), ``coverage``, ``chi2`` (before and after the maps) and
``profiles`` (residuals along each scanned leg).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from ogacq.diagnose.outcome import outcome_label
from ogacq.errors import InputError
from ogacq.model.axis_map import AxisMap
from ogacq.record.declared import RecordSectionError, Section, read


class DiagnosisFormatError(InputError):
    """The diagnosis JSON does not have the shape of INTERCHANGE.md."""

    def __init__(self, problem: str) -> None:
        super().__init__(None, problem)


@dataclass(frozen=True)
class ModelAgreement(Section):
    """How well one of the diagnosis's models (its base or final) fits the readings."""

    consistent: bool
    chi2_dof: float | None = None
    rms_mm: float | None = None


@dataclass(frozen=True)
class MisfitShare(Section):
    share: float
    leg: str | None = None
    gauge_axis: str | None = None

    @property
    def gauge(self) -> str:
        return f"{self.gauge_axis}_{self.leg}"


@dataclass(frozen=True)
class Alternative(Section):
    effect: str
    where: str = "?"


@dataclass(frozen=True)
class EffectFound(Section):
    effect: str  # a name like "squareness"
    where: str = ""
    value: float | None = None
    std: float | None = None
    unit: str | None = None
    alternatives: tuple[Alternative, ...] = ()
    separated_by: tuple[str, ...] = ()
    located: str | None = None  # an error map's place and shape, in words

    @property
    def name(self) -> str:
        return f"{self.effect}.{self.where}"

    @property
    def alternative_names(self) -> tuple[str, ...]:
        return tuple(f"{a.effect}.{a.where}" for a in self.alternatives)

    @property
    def unexplained(self) -> bool:
        return self.effect == "unexplained"


@dataclass(frozen=True)
class GaugeProfile(Section):
    before_um: tuple[float | None, ...]  # null: no reading in that bin
    after_um: tuple[float | None, ...]


@dataclass(frozen=True)
class LegProfile(Section):
    """Residuals along one scanned leg: bin centres (mm), per gauge the mean residual
    before and after (µm)."""

    q_mm: tuple[float | None, ...]
    leg: str | None = None
    gauges: dict[str, GaugeProfile] = field(default_factory=dict)


@dataclass(frozen=True)
class ModelChi2(Section):
    p: float
    statistic: float | None = None
    dof: int | None = None
    consistent: bool | None = None


@dataclass(frozen=True)
class _Parameters(Section):
    joint_offset: dict[str, float | None] = field(default_factory=dict)


@dataclass(frozen=True)
class _Proposal(Section):
    text: str | None = None


@dataclass(frozen=True)
class _Coverage(Section):
    """How one axis was read; the values are shown as written."""

    axis: Any = None
    positions: Any = None
    maps_searched: Any = None
    from_mm: Any = None
    to_mm: Any = None
    step_mm: Any = None

    def words(self) -> str:
        where = f"{self.axis} axis: {self.positions} positions read"
        if self.maps_searched:
            return where + (f", {self.from_mm} to {self.to_mm} mm every {self.step_mm} mm: "
                            "searched for maps along it")
        return where + ": too few for a map along it (a scan would show one)"


@dataclass(frozen=True)
class _Diagnosis(Section):
    """INTERCHANGE.md's diagnosis object, and the optional keys the module names."""

    noise_mm: float
    base: ModelAgreement
    final: ModelAgreement
    located: tuple[MisfitShare, ...] = ()
    effects: tuple[EffectFound, ...] = ()
    parameters: _Parameters = field(default_factory=_Parameters)
    caveats: tuple[Any, ...] = ()
    maps: tuple[Any, ...] = ()  # ogacq-axis-map/1 objects, read by AxisMap.from_json
    proposals: tuple[_Proposal, ...] = ()
    coverage: tuple[_Coverage, ...] = ()
    chi2: dict[str, ModelChi2] = field(default_factory=dict)  # base, library, final
    profiles: tuple[LegProfile, ...] = ()


@dataclass(frozen=True)
class DiagnosisView:
    noise_mm: float
    base: ModelAgreement
    final: ModelAgreement
    located: tuple[MisfitShare, ...]
    effects: tuple[EffectFound, ...]
    offsets_mm: dict[str, float]  # the final model's joint offsets, by axis
    caveats: tuple[str, ...] = ()
    maps: tuple[AxisMap, ...] = ()
    proposals: tuple[str, ...] = ()
    coverage: tuple[str, ...] = ()  # how densely each axis was read, in words
    chi2: dict[str, ModelChi2] = field(default_factory=dict)  # base, library, final
    profiles: tuple[LegProfile, ...] = ()

    @property
    def named_effects(self) -> tuple[EffectFound, ...]:
        return tuple(e for e in self.effects if not e.unexplained)

    @property
    def unexplained_where(self) -> str | None:
        return next((e.where for e in self.effects if e.unexplained), None)

    @property
    def outcome(self) -> str:
        return outcome_label(self.base.consistent, self.final.consistent,
                             bool(self.named_effects),
                             self.base.consistent or self.base.chi2_dof is not None)


def _maps(found: tuple[Any, ...]) -> tuple[AxisMap, ...]:
    out = []
    for k, m in enumerate(found):
        if not isinstance(m, dict):
            raise DiagnosisFormatError(f"maps[{k}] must be an object, got {type(m).__name__}")
        try:
            out.append(AxisMap.from_json(m, f"maps[{k}]"))
        except (InputError, ValueError) as exc:
            raise DiagnosisFormatError(f"maps[{k}]: {exc}") from None
    return tuple(out)


def parse_diagnosis(data: Any) -> DiagnosisView:
    """Check ``data`` against INTERCHANGE.md's diagnosis object; raises
    DiagnosisFormatError naming the first key that is wrong."""
    if isinstance(data, dict):
        for key in ("noise_mm", "base", "final"):
            if key not in data:
                raise DiagnosisFormatError(f"the diagnosis has no '{key}' (see `ogacq "
                                           "diagnose --json`)")
    try:
        d = read(_Diagnosis, data, "diagnosis")
    except RecordSectionError as exc:
        raise DiagnosisFormatError(f"{exc.key} {exc.problem_of_key}") from None
    return DiagnosisView(
        noise_mm=d.noise_mm, base=d.base, final=d.final, located=d.located, effects=d.effects,
        offsets_mm={a: v for a, v in d.parameters.joint_offset.items() if v is not None},
        caveats=tuple(str(c) for c in d.caveats), maps=_maps(d.maps),
        proposals=tuple(p.text for p in d.proposals if p.text),
        coverage=tuple(c.words() for c in d.coverage), chi2=d.chi2, profiles=d.profiles)
