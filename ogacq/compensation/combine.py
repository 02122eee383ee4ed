"""One compensation map per axis, each error corrected once.

The inputs: the maps the diagnosis identified (a lead-screw map, a rail bow, a
hysteresis: ``AxisMap``), the library effects of its final model that a table can
hold (``effects.effect_maps``), and the maps already applied when the campaign
ran (its readings then show only what is left). The rules:

1. a constant is a joint offset: each map is made zero at its reference forward,
   and what is taken off moves to the axis's offset (``offset_shift_mm``);
2. an effect the model carries on its own (an encoder scale, a backlash of the
   final model) is corrected from the model's value: a diagnosis map that is not
   already orthogonal to it (``excludes`` does not name it) has that effect's
   signature projected out first, so the two never correct the same error twice;
3. the rest add up on the union of the positions (linear between them, as every
   map interpolates), their uncertainties in quadrature (independent estimates);
4. a map goes with the controller coordinate the offsets written beside it make
   (``with_offsets``): moved by the coordinate's change, zero at the reference of that
   coordinate, its new constant a part of the offset as in rule 1.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field, replace

import numpy as np

from ogacq.compensation.effects import EffectMap
from ogacq.model.axis_map import AxisMap
from ogacq.model.error_maps import moved_terms_json
from ogacq.model.parameters import AXES

# Positions closer than this are one point of a sum: a map rounded to 1e-9 mm and one
# over the same span unrounded differ by less (LinuxCNC refuses a nominal that does not
# increase; every table would list the point twice). Far below any table's spacing.
SAME_POSITION_MM = 1e-6

# The signature each carried effect leaves in a map, per side: (forward, reverse) as
# functions of q (see ogacq.compensation.effects: e = s q - a b / 2).
SIGNATURES = {
    "encoder_scale": lambda q: (q, q),
    "backlash": lambda q: (-0.5 * np.ones_like(q), 0.5 * np.ones_like(q)),
}


@dataclass(frozen=True)
class AxisCompensation:
    axis: str
    axis_map: AxisMap  # zero at its reference forward
    offset_shift_mm: float  # add to the identified joint offset
    parts: tuple[str, ...] = ()  # what went into it, in words
    removed: tuple[str, ...] = field(default_factory=tuple)  # projected out (rule 2)


def zeroed(m: AxisMap) -> tuple[AxisMap, float]:
    """The map less its forward error at the reference, and that constant."""
    c = float(m.error_mm(m.reference_mm, 1))
    if c == 0.0:
        return m, 0.0
    return replace(m, forward_mm=tuple(v - c for v in m.forward_mm),
                   reverse_mm=tuple(v - c for v in m.reverse_mm)), c


def with_offsets(m: AxisMap, moved_mm: float, reference_mm: float = 0.0,
                 ) -> tuple[AxisMap, float]:
    """The map in the controller coordinate that new joint offsets make, the joint at
    ``q`` before being at ``q + moved_mm`` after (``AxisMap.moved``), zero at
    ``reference_mm`` of that coordinate forward; and the constant taken off (rule 1: the
    offset's). The map's ``extra["moved_with_offsets_mm"]`` adds up the moves it went
    through."""
    if moved_mm == 0.0 and m.reference_mm == reference_mm:
        return m, 0.0
    extra = {**m.extra, "moved_with_offsets_mm":
             round(float(m.extra.get("moved_with_offsets_mm", 0.0)) + moved_mm, 9)}
    if m.extra.get("terms"):  # the shapes it was made from, in the new coordinate too
        extra["terms"] = moved_terms_json(list(m.extra["terms"]), moved_mm)
    if m.extra.get("measured_mm"):  # where the readings were
        extra["measured_mm"] = [float(v) + moved_mm for v in m.extra["measured_mm"]]
    return zeroed(replace(m.moved(moved_mm), reference_mm=reference_mm, extra=extra))


def without(m: AxisMap, carried: Iterable[str]) -> tuple[AxisMap, tuple[str, ...]]:
    """The map with the signatures of the ``carried`` effects (``encoder_scale.x``)
    it is not orthogonal to projected out (least squares over both sides)."""
    q = np.asarray(m.positions_mm, float)
    todo = [name for name in carried if name not in m.excludes
            and name.split(".")[0] in SIGNATURES and name.endswith(f".{m.axis}")]
    if not todo:
        return m, ()
    y = np.concatenate([m.forward_mm, m.reverse_mm])
    columns = [np.concatenate(SIGNATURES[name.split(".")[0]](q)) for name in todo]
    basis = np.column_stack([*columns, np.ones_like(y)])  # the constant is rule 1's
    coef, *_ = np.linalg.lstsq(basis, y, rcond=None)
    rest = y - basis[:, :-1] @ coef[:-1]
    n = len(q)
    return replace(m, forward_mm=tuple(rest[:n]), reverse_mm=tuple(rest[n:]),
                   excludes=(*m.excludes, *todo)), tuple(todo)


def summed(axis: str, maps: Sequence[AxisMap], reference_mm: float) -> AxisMap:
    """The maps added on the union of their positions (those ``SAME_POSITION_MM``
    apart taken once)."""
    q = np.unique(np.concatenate([np.asarray(m.positions_mm, float) for m in maps]))
    q = q[np.concatenate([[True], np.diff(q) > SAME_POSITION_MM])]
    fwd = np.sum([m.error_mm(q, 1) for m in maps], axis=0)
    rev = np.sum([m.error_mm(q, -1) for m in maps], axis=0)
    u_f = np.sqrt(np.sum([np.interp(q, m.positions_mm, m.u_forward_mm) ** 2 for m in maps],
                         axis=0))
    u_r = np.sqrt(np.sum([np.interp(q, m.positions_mm, m.u_reverse_mm) ** 2 for m in maps],
                         axis=0))
    excludes = tuple(dict.fromkeys(e for m in maps for e in m.excludes))
    return AxisMap(axis, tuple(float(v) for v in q), tuple(float(v) for v in fwd),
                   tuple(float(v) for v in rev), tuple(float(v) for v in u_f),
                   tuple(float(v) for v in u_r), reference_mm,
                   "; ".join(m.source for m in maps if m.source), excludes, _extras(maps))


def _extras(maps: Sequence[AxisMap]) -> dict:
    """What the maps say beside their values, for their sum: the lists joined (their
    terms, families, effects), any other entry the first one's (a pitch, where the
    readings were); not the moves each went through (the sum is a map of this
    coordinate)."""
    out: dict = {}
    for m in maps:
        for key, value in m.extra.items():
            if key == "moved_with_offsets_mm":
                continue
            if isinstance(value, list) and key != "measured_mm":
                out[key] = [*out.get(key, []), *value]
            else:
                out.setdefault(key, value)
    return out


def compensation(diagnosis_maps: Sequence[AxisMap], effect_maps: Mapping[str, EffectMap],
                 carried: Iterable[str], in_force: Mapping[str, AxisMap] | None = None,
                 ) -> dict[str, AxisCompensation]:
    """Per axis, the map to correct and the constant that goes to its offset.

    ``carried``: the effects of the final model (their library maps are in
    ``effect_maps``); ``in_force``: maps applied while the campaign ran, to which
    what it identified adds."""
    carried = tuple(carried)
    out: dict[str, AxisCompensation] = {}
    for axis in AXES:
        maps: list[AxisMap] = []
        parts: list[str] = []
        removed: list[str] = []
        shift = 0.0
        for m in (m for m in diagnosis_maps if m.axis == axis):
            m, gone = without(m, carried)
            m, c = zeroed(m)
            maps.append(m)
            shift += c
            removed += gone
            parts.append(m.source or "diagnosis map")
        if axis in effect_maps:
            maps.append(effect_maps[axis].axis_map)
            shift += effect_maps[axis].offset_shift_mm
            parts.append(effect_maps[axis].axis_map.source)
        if not maps:
            continue  # nothing new: a map in force stays as it is
        if in_force and axis in in_force:
            # in force already: the campaign saw what it left; the offsets in force
            # were written with its constant, so it adds no shift
            maps.append(in_force[axis])
            parts.append("the map in force during the campaign")
        reference = maps[0].reference_mm
        total, c = zeroed(summed(axis, maps, reference))
        out[axis] = AxisCompensation(axis, total, shift + c, tuple(parts), tuple(removed))
    return out
