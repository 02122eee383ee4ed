"""What a diagnosis hands to the compensation: its error maps, and its library effects
a table can hold.

``diagnosis_maps`` is the one place the procedure takes the diagnosis's maps from:
the diagnosis puts the maps it identifies (a lead screw's periodic error, a smooth
screw map, a rail bow, a hysteresis) on its result as a tuple of ``AxisMap``
(``Diagnosis.maps``); a diagnosis that identifies none has none.
"""

from __future__ import annotations

from ogacq.compensation.effects import EffectValue, compensable
from ogacq.diagnose.diagnosis import Diagnosis, EffectFound
from ogacq.model.axis_map import AxisMap


def diagnosis_maps(diagnosis: Diagnosis) -> tuple[AxisMap, ...]:
    """The error maps the diagnosis identified (none when it identifies none)."""
    return diagnosis.maps


def model_effects(diagnosis: Diagnosis) -> dict[str, EffectValue]:
    """Every library effect of the diagnosis's final model, with its value and std (its
    error maps are not effects of the vocabulary: they come as maps)."""
    return {e.name: EffectValue(e.name, float(e.value), float(e.std))
            for e in diagnosis.effects if isinstance(e, EffectFound)}


def compensable_effects(diagnosis: Diagnosis) -> dict[str, EffectValue]:
    """The effects of the final model a per-joint table corrects (encoder scale, lost
    motion): those the controller can compensate."""
    return {n: v for n, v in model_effects(diagnosis).items() if compensable(n)}


def uncompensated_effects(diagnosis: Diagnosis) -> list[str]:
    """The effects of the final model no table corrects: they stay (a squareness until
    the machine is adjusted)."""
    return [n for n in model_effects(diagnosis) if not compensable(n)]
