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
class ModelAgreement:
    """How well one of the diagnosis's models (its base or final) fits the readings."""

    chi2_dof: float | None
    rms_mm: float | None
    consistent: bool


@dataclass(frozen=True)
class MisfitShare:
    leg: str
    gauge_axis: str
    share: float

    @property
    def gauge(self) -> str:
        return f"{self.gauge_axis}_{self.leg}"


@dataclass(frozen=True)
class EffectFound:
    effect: str
    where: str
    value: float | None
    std: float | None
    unit: str
    alternatives: tuple[str, ...] = ()
    separated_by: tuple[str, ...] = ()
    located: str | None = None  # an error map's place and shape, in words

    @property
    def name(self) -> str:
        return f"{self.effect}.{self.where}"

    @property
    def unexplained(self) -> bool:
        return self.effect == "unexplained"


@dataclass(frozen=True)
class LegProfileView:
    """Residuals along one scanned leg (``profiles``): bin centres (mm), per gauge the
    mean residual before and after (µm, NaN where empty)."""

    leg: str
    q_mm: tuple[float, ...]
    before_um: dict[str, tuple[float, ...]]
    after_um: dict[str, tuple[float, ...]]


@dataclass(frozen=True)
class ModelChi2:
    statistic: float | None
    dof: int
    p: float
    consistent: bool


@dataclass(frozen=True)
class DiagnosisView:
    noise_mm: float
    base: ModelAgreement
    final: ModelAgreement
    located: tuple[MisfitShare, ...]
    effects: tuple[EffectFound, ...]
    offsets_mm: dict[str, float]  # the final model's joint offsets, by axis
    caveats: tuple[str, ...] = field(default_factory=tuple)
    maps: tuple[AxisMap, ...] = ()
    proposals: tuple[str, ...] = ()
    coverage: tuple[str, ...] = ()  # how densely each axis was read, in words
    chi2: dict[str, ModelChi2] = field(default_factory=dict)  # base, library, final
    profiles: tuple[LegProfileView, ...] = ()

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


# --- the JSON, declared once (ogacq.record.declared) -----------------------------------

@dataclass(frozen=True)
class _Agreement(Section):
    consistent: bool
    chi2_dof: float | None = None
    rms_mm: float | None = None


@dataclass(frozen=True)
class _Located(Section):
    share: float
    leg: str | None = None
    gauge_axis: str | None = None


@dataclass(frozen=True)
class _Alternative(Section):
    effect: str
    where: str = "?"


@dataclass(frozen=True)
class _Effect(Section):
    effect: str  # a name like "squareness"
    where: str = ""
    value: float | None = None
    std: float | None = None
    unit: str | None = None
    alternatives: tuple[_Alternative, ...] = ()
    separated_by: tuple[str, ...] = ()
    located: str | None = None


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


@dataclass(frozen=True)
class _Chi2(Section):
    p: float
    statistic: float | None = None
    dof: int | None = None
    consistent: bool | None = None


@dataclass(frozen=True)
class _GaugeProfile(Section):
    before_um: tuple[float | None, ...]  # null: no reading in that bin
    after_um: tuple[float | None, ...]


@dataclass(frozen=True)
class _Profile(Section):
    q_mm: tuple[float | None, ...]
    leg: str | None = None
    gauges: dict[str, _GaugeProfile] = field(default_factory=dict)


@dataclass(frozen=True)
class _Diagnosis(Section):
    """INTERCHANGE.md's diagnosis object, and the optional keys the module names."""

    noise_mm: float
    base: _Agreement
    final: _Agreement
    located: tuple[_Located, ...] = ()
    effects: tuple[_Effect, ...] = ()
    parameters: _Parameters = field(default_factory=_Parameters)
    caveats: tuple[Any, ...] = ()
    maps: tuple[Any, ...] = ()  # ogacq-axis-map/1 objects, read by AxisMap.from_json
    proposals: tuple[_Proposal, ...] = ()
    coverage: tuple[_Coverage, ...] = ()
    chi2: dict[str, _Chi2] = field(default_factory=dict)  # base, library, final
    profiles: tuple[_Profile, ...] = ()


def _agreement(d: _Agreement) -> ModelAgreement:
    return ModelAgreement(_float(d.chi2_dof), _float(d.rms_mm), d.consistent)


def _float(value: float | None) -> float | None:
    return None if value is None else float(value)


def _effect(d: _Effect) -> EffectFound:
    return EffectFound(d.effect, d.where, _float(d.value), _float(d.std), d.unit or "-",
                       tuple(f"{a.effect}.{a.where}" for a in d.alternatives),
                       d.separated_by, d.located)


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


def _floats(values: tuple[float | None, ...]) -> tuple[float, ...]:
    """A profile's values, an empty bin (null) as NaN."""
    return tuple(float("nan") if v is None else float(v) for v in values)


def _profile(p: _Profile) -> LegProfileView:
    return LegProfileView(str(p.leg), _floats(p.q_mm),
                          {g: _floats(v.before_um) for g, v in p.gauges.items()},
                          {g: _floats(v.after_um) for g, v in p.gauges.items()})


def _coverage(c: _Coverage) -> str:
    where = f"{c.axis} axis: {c.positions} positions read"
    if c.maps_searched:
        return where + (f", {c.from_mm} to {c.to_mm} mm every {c.step_mm} mm: searched "
                        "for maps along it")
    return where + ": too few for a map along it (a scan would show one)"


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
        noise_mm=float(d.noise_mm), base=_agreement(d.base), final=_agreement(d.final),
        located=tuple(MisfitShare(str(g.leg), str(g.gauge_axis), float(g.share))
                      for g in d.located),
        effects=tuple(_effect(e) for e in d.effects),
        offsets_mm={a: float(v) for a, v in d.parameters.joint_offset.items()
                    if v is not None},
        caveats=tuple(str(c) for c in d.caveats), maps=_maps(d.maps),
        proposals=tuple(p.text for p in d.proposals if p.text),
        coverage=tuple(_coverage(c) for c in d.coverage),
        chi2={key: ModelChi2(_float(v.statistic), v.dof or 0, float(v.p), bool(v.consistent))
              for key, v in d.chi2.items()},
        profiles=tuple(_profile(p) for p in d.profiles))
