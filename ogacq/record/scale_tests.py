"""The record's ``axis_scales`` section (``ogacq.record.axis_scales``) built from an
``ogacq calibrate`` procedure's log.

The procedure logs each positioning test's session (its ``campaign`` steps, roles
``positioning-before-x`` and ``positioning-after-x``, ``-2`` for a second round), what
the test before found along the axis (``scale maps``) and the validation of the
written map by the test after (``scales``): read back here, so that the record states
what the procedure decided from. The figures are net of the drive's rounding of each
corrected target, as the procedure judged them (``ogacq.calibration.scale_check``).
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

from ogacq.model.instrument import Instrument
from ogacq.model.parameters import AXES
from ogacq.protocol.positioning import session_result
from ogacq.record.context import calibration_context
from ogacq.record.identity import session_digest
from ogacq.session.records import CalibrateRecord
from ogacq.session.store import LoadedSession, load_session

__all__ = ["axis_scales_section"]


def axis_scales_section(log: LoadedSession) -> dict[str, Any] | None:
    """The ``axis_scales`` section of the procedure whose log is ``log`` (JSON), None
    when it tested no axis by a scale. Its sessions are read from the log's folder."""
    steps = log.of_type(CalibrateRecord)
    finished = [str(s.details["role"]) for s in steps
                if s.step == "campaign" and s.details.get("status") == "finished"
                and str(s.details.get("role", "")).startswith("positioning-")]
    folder = Path(log.path).parent
    out: dict[str, Any] = {}
    for axis in AXES:
        before = f"positioning-before-{axis}"
        if before not in finished:
            continue
        afters = [r for r in finished if r == f"positioning-after-{axis}"
                  or r.startswith(f"positioning-after-{axis}-")]
        tested = load_session(folder / f"{before}.jsonl")
        entry: dict[str, Any] = {"instrument": _instrument(tested, axis),
                                 "before": _test(tested)}
        found = _last(steps, "scale maps", "fits", axis)
        if found is not None:
            entry["found"] = _found(found)
        if afters:
            entry["after"] = _test(load_session(folder / f"{afters[-1]}.jsonl"))
            check = _last(steps, "scales", "checks", axis)
            if check is not None:
                entry["validation"] = {"shown": bool(check["shown"]),
                                       "within": int(check["within"]),
                                       "targets": len(check["targets_mm"]),
                                       "worse": check.get("worse")}
        out[axis] = entry
    return out or None


def _test(session: LoadedSession) -> dict[str, Any]:
    result = session_result(session, net_of_drive=True)
    _, sha256 = session_digest(session)
    return {"session": {"path": str(Path(session.path).resolve()), "sha256": sha256,
                        "records": len(session.records)},
            "targets": len(result.targets_mm), "runs": result.runs,
            "iso230_2": result.figures.to_json()}


def _instrument(session: LoadedSession, axis: str) -> dict[str, Any]:
    """The scale as the test's session recorded it, and whether it was past its due
    date on the test's date (a session from before its instrument was recorded: the
    serial and display step its station opened it with)."""
    context = calibration_context(session)
    scale = context.instrument(f"scale_{axis}")
    if scale is None:
        opened = ((session.header.station or {}).get("axis_scales") or {}).get(axis) or {}
        scale = Instrument(f"scale_{axis}", serial=opened.get("serial") or None,
                           resolution_mm=opened.get("resolution_mm"))
    return dict(scale.to_json(), expired=context.expired(scale))


def _found(fit: Mapping[str, Any]) -> dict[str, Any]:
    cyclic = fit.get("found")
    if not isinstance(cyclic, Mapping):
        return {"flat": bool(fit.get("flat"))}
    return {"flat": False, "pitch_mm": cyclic["pitch_mm"],
            "pitch_std_mm": cyclic["pitch_std_mm"], "amplitude_mm": cyclic["amplitude_mm"]}


def _last(steps: list[CalibrateRecord], step: str, key: str,
          axis: str) -> Mapping[str, Any] | None:
    """The latest ``step``'s ``key`` entry of ``axis`` (the last round's)."""
    for record in reversed(steps):
        by_axis = record.details.get(key) if record.step == step else None
        if isinstance(by_axis, Mapping) and isinstance(by_axis.get(axis), Mapping):
            return by_axis[axis]
    return None
