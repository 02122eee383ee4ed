"""Plausibility before any answer: data that cannot be millimetres of this machine,
data too thin for the parameters asked, and results no encoder zero error can be.

A micrometre column labelled ``value_mm`` fits as well as the right one, and a
single row fits three offsets exactly; both give numbers with exit 0 unless
someone looks first. This is that look, in one place for every command.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ogacq.identify.fit import FitResult
from ogacq.identify.observations import Observations
from ogacq.io.errors import InputError
from ogacq.model.parameters import effect_of

# The longest travel of the dial and digital indicators sold for this work (2 in,
# e.g. Mitutoyo's 50.8 mm series): no gauge reads a deviation beyond it.
MAX_GAUGE_TRAVEL_MM = 50.8
# A joint offset beyond this share of the leg length is no encoder zero error: the
# machine could not have been assembled, or the data are not in mm.
MAX_OFFSET_SHARE_OF_LEG = 0.05


def check_observations(obs: Observations, names: Sequence[str] = ()) -> None:
    """Refuse data no gauge could have read, or too few for ``names``."""
    where = obs.source or "data"
    if obs.raw:
        lay = obs.layout
        for g, name in enumerate(lay.gauge_names()):
            values = obs.values[lay.gauge == g]
            span = float(values.max() - values.min()) if len(values) else 0.0
            if span > MAX_GAUGE_TRAVEL_MM:
                raise InputError(where, f"gauge {name} spans {span:g} mm, beyond the "
                                 f"{MAX_GAUGE_TRAVEL_MM:g} mm travel of any indicator: are "
                                 "these readings in mm?")
    else:
        for label, value in zip(obs.labels, obs.values, strict=True):
            if abs(value) > MAX_GAUGE_TRAVEL_MM:
                raise InputError(where, f"{label} = {value:g} mm is beyond the "
                                 f"{MAX_GAUGE_TRAVEL_MM:g} mm travel of any indicator: are "
                                 "these deviations in µm in a value_mm column?")
    independent = len(obs) - obs.n_nuisance
    if names and independent < len(names):
        what = "readings beyond each gauge's zero" if obs.raw else "deviations"
        raise InputError(where, f"{independent} {what} for {len(names)} parameters "
                         f"({', '.join(names)}): too few to identify them")


def check_result(result: FitResult) -> None:
    """Refuse identified values that cannot be this machine's. Parameters the data do
    not determine are left to the identifiability report, which says so."""
    obs = result.observations
    where = obs.source or "data"
    leg = obs.machine.leg_length_mm
    limit = MAX_OFFSET_SHARE_OF_LEG * leg
    loose = set(result.identifiability.unidentified)
    for name, value in zip(result.names, result.values, strict=True):
        if name in loose:
            continue
        kind = effect_of(name)
        if name.startswith(("joint_offset.", "leg_length.")) and abs(value) > limit:
            raise InputError(where, f"identified {name} = {value:+.4g} mm is beyond "
                             f"{MAX_OFFSET_SHARE_OF_LEG:.0%} of the {leg:g} mm leg: not "
                             "millimetres of this machine (µm in a mm column? another "
                             "machine's file?)")
        if not np.isfinite(value):
            raise InputError(where, f"identified {name} is not a number: the data do not "
                             f"determine it ({kind.unit})")

