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
from typing import Any, Literal, overload

from ogacq.diagnose.outcome import outcome_label
from ogacq.errors import InputError
from ogacq.model.axis_map import AxisMap


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


@overload
def _number(d: dict, key: str, where: str, optional: Literal[False] = False) -> float: ...


@overload
def _number(d: dict, key: str, where: str, optional: bool) -> float | None: ...


def _number(d: dict, key: str, where: str, optional: bool = False) -> float | None:
    value = d.get(key)
    if value is None and optional:
        return None
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise DiagnosisFormatError(f"{where}.{key} must be a number, got {value!r}")
    return float(value)


def _object(d: Any, where: str) -> dict:
    if not isinstance(d, dict):
        raise DiagnosisFormatError(f"{where} must be an object, got {type(d).__name__}")
    return d


def _verdict(d: Any, where: str) -> ModelAgreement:
    d = _object(d, where)
    if not isinstance(d.get("consistent"), bool):
        raise DiagnosisFormatError(f"{where}.consistent must be true or false")
    return ModelAgreement(_number(d, "chi2_dof", where, True), _number(d, "rms_mm", where, True),
                      d["consistent"])


def _alternative(a: Any) -> str:
    if isinstance(a, dict) and "effect" in a:
        return f"{a['effect']}.{a.get('where', '?')}"
    return str(a)


def _effect(d: Any, k: int) -> EffectFound:
    where = f"effects[{k}]"
    d = _object(d, where)
    if not isinstance(d.get("effect"), str):
        raise DiagnosisFormatError(f"{where}.effect must be a name like 'squareness'")
    alternatives = d.get("alternatives") or []
    separated = d.get("separated_by") or []
    if not isinstance(alternatives, list) or not isinstance(separated, list):
        raise DiagnosisFormatError(f"{where}.alternatives must be a list")
    located = d.get("located")
    return EffectFound(d["effect"], str(d.get("where", "")),
                       _number(d, "value", where, True), _number(d, "std", where, True),
                       str(d.get("unit") or "-"), tuple(_alternative(a) for a in alternatives),
                       tuple(str(s) for s in separated),
                       str(located) if isinstance(located, str) else None)


def _list(d: dict, key: str) -> list:
    value = d.get(key) or []
    if not isinstance(value, list):
        raise DiagnosisFormatError(f"{key} must be a list")
    return value


def _maps(d: dict) -> tuple[AxisMap, ...]:
    out = []
    for k, m in enumerate(_list(d, "maps")):
        try:
            out.append(AxisMap.from_json(_object(m, f"maps[{k}]"), f"maps[{k}]"))
        except (InputError, ValueError) as exc:
            raise DiagnosisFormatError(f"maps[{k}]: {exc}") from None
    return tuple(out)


def _floats(values: Any, where: str) -> tuple[float, ...]:
    if not isinstance(values, list):
        raise DiagnosisFormatError(f"{where} must be a list of numbers")
    return tuple(float("nan") if v is None else float(v) for v in values)


def _profiles(d: dict) -> tuple[LegProfileView, ...]:
    out = []
    for k, p in enumerate(_list(d, "profiles")):
        where = f"profiles[{k}]"
        p = _object(p, where)
        gauges = _object(p.get("gauges") or {}, f"{where}.gauges")
        out.append(LegProfileView(
            str(p.get("leg")), _floats(p.get("q_mm"), f"{where}.q_mm"),
            {g: _floats(_object(v, g).get("before_um"), f"{where}.{g}") for g, v in gauges.items()},
            {g: _floats(_object(v, g).get("after_um"), f"{where}.{g}") for g, v in gauges.items()}))
    return tuple(out)


def _chi2(d: dict) -> dict[str, ModelChi2]:
    out = {}
    for key, v in _object(d.get("chi2") or {}, "chi2").items():
        v = _object(v, f"chi2.{key}")
        out[str(key)] = ModelChi2(_number(v, "statistic", f"chi2.{key}", True),
                                  int(v.get("dof") or 0),
                                  float(_number(v, "p", f"chi2.{key}") or 0.0),
                                  bool(v.get("consistent")))
    return out


def _coverage(d: dict) -> tuple[str, ...]:
    out = []
    for c in _list(d, "coverage"):
        if not isinstance(c, dict):
            continue
        where = f"{c.get('axis')} axis: {c.get('positions')} positions read"
        if c.get("maps_searched"):
            where += (f", {c.get('from_mm')} to {c.get('to_mm')} mm every "
                      f"{c.get('step_mm')} mm: searched for maps along it")
        else:
            where += ": too few for a map along it (a scan would show one)"
        out.append(where)
    return tuple(out)


def parse_diagnosis(data: Any) -> DiagnosisView:
    """Check ``data`` against INTERCHANGE.md's diagnosis object; raises
    DiagnosisFormatError naming the first key that is wrong."""
    d = _object(data, "diagnosis")
    for key in ("noise_mm", "base", "final"):
        if key not in d:
            raise DiagnosisFormatError(f"the diagnosis has no '{key}' (see `ogacq diagnose "
                                       "--json`)")
    located = []
    for k, g in enumerate(d.get("located") or []):
        g = _object(g, f"located[{k}]")
        located.append(MisfitShare(str(g.get("leg")), str(g.get("gauge_axis")),
                                   _number(g, "share", f"located[{k}]")))
    offsets = _object(d.get("parameters") or {}, "parameters").get("joint_offset") or {}
    caveats = d.get("caveats") or []
    return DiagnosisView(
        noise_mm=_number(d, "noise_mm", "diagnosis"),
        base=_verdict(d["base"], "base"), final=_verdict(d["final"], "final"),
        located=tuple(located),
        effects=tuple(_effect(e, k) for k, e in enumerate(d.get("effects") or [])),
        offsets_mm={str(a): float(v) for a, v in _object(offsets, "parameters.joint_offset")
                    .items() if isinstance(v, int | float)},
        caveats=tuple(str(c) for c in caveats) if isinstance(caveats, list) else (),
        maps=_maps(d),
        proposals=tuple(str(p.get("text")) for p in _list(d, "proposals")
                        if isinstance(p, dict) and p.get("text")),
        coverage=_coverage(d), chi2=_chi2(d), profiles=_profiles(d))
