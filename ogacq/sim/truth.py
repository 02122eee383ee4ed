"""The simulated machine's hidden truth: geometry, effects and gauge behaviour.

An effects file (TOML) names any entries of the INTERCHANGE.md vocabulary, one
table per effect, plus the gauges' noise and an out-of-library lead-screw error
(so that the diagnosis can be shown an effect it does not know)::

    [joint_offset]        # mm
    x = 0.42
    [squareness]          # mrad
    xy = 0.5
    [gauges]
    noise_mm = 0.001
    [lead_screw.x]        # periodic error of the x screw, not in the vocabulary
    amplitude_mm = 0.01
    pitch_mm = 10.0
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ogacq.io.errors import InputError
from ogacq.io.toml_file import line_of, read_toml
from ogacq.model.parameters import AXES, EFFECT_BY_NAME, PARAM_INDEX, vector


@dataclass(frozen=True)
class LeadScrewError:
    amplitude_mm: float
    pitch_mm: float


@dataclass
class SimTruth:
    theta: np.ndarray  # full parameter vector (ogacq.model.parameters order)
    noise_mm: float = 0.001
    lead_screw: dict[int, LeadScrewError] = field(default_factory=dict)

    def hidden(self) -> dict[str, float]:
        """The non-nominal entries: what a calibration should find."""
        from ogacq.model.parameters import non_nominal

        return non_nominal(self.theta)

    def disturbed_q(self, q_mm: np.ndarray) -> np.ndarray:
        """Joint coordinates as the physics sees them: the lead-screw error added."""
        out = np.array(q_mm, dtype=float)
        for axis, err in self.lead_screw.items():
            out[..., axis] += err.amplitude_mm * np.sin(2 * np.pi * out[..., axis] / err.pitch_mm)
        return out


def random_truth(seed: int, offsets_mm: float = 1.5, noise_mm: float = 0.001) -> SimTruth:
    """Hidden joint offsets drawn from the seed, everything else nominal."""
    rng = np.random.default_rng(seed)
    values = {f"joint_offset.{a}": float(v)
              for a, v in zip(AXES, rng.uniform(-offsets_mm, offsets_mm, 3), strict=True)}
    return SimTruth(vector(values), noise_mm)


def read_effects(path: str | Path, base: SimTruth) -> SimTruth:
    """``base`` with the effects file's entries applied on top."""
    path = Path(path)
    try:
        data, text = read_toml(path, "effects file")
    except FileNotFoundError:
        raise InputError(path, "no such effects file") from None
    theta = base.theta.copy()
    noise = base.noise_mm
    lead: dict[int, LeadScrewError] = dict(base.lead_screw)
    for section, entries in data.items():
        if not isinstance(entries, dict):
            raise InputError(path, f"{section!r} must be a table like [{section}]",
                             line_of(text, section))
        if section == "gauges":
            for key, value in entries.items():
                if key != "noise_mm" or not _is_number(value) or value < 0:
                    raise InputError(path, f"[gauges] takes noise_mm = a number >= 0, got "
                                     f"{key} = {value!r}", line_of(text, key))
                noise = float(value)
            continue
        if section == "lead_screw":
            for axis, spec in entries.items():
                if axis not in AXES or not isinstance(spec, dict) or \
                        set(spec) != {"amplitude_mm", "pitch_mm"} or \
                        not all(_is_number(v) for v in spec.values()) or spec["pitch_mm"] <= 0:
                    raise InputError(path, f"[lead_screw.{axis}] needs axis x, y or z with "
                                     "amplitude_mm and pitch_mm > 0", line_of(text, axis))
                lead[AXES.index(axis)] = LeadScrewError(float(spec["amplitude_mm"]),
                                                        float(spec["pitch_mm"]))
            continue
        effect = EFFECT_BY_NAME.get(section)
        if effect is None:
            raise InputError(path, f"unknown effect [{section}]; known: "
                             f"{', '.join(EFFECT_BY_NAME)}, gauges, lead_screw",
                             line_of(text, section))
        for where, value in entries.items():
            name = f"{section}.{where}"
            if name not in PARAM_INDEX:
                raise InputError(path, f"[{section}] has no {where!r}; it takes "
                                 f"{', '.join(effect.wheres)}", line_of(text, where))
            if not _is_number(value):
                raise InputError(path, f"{name} must be a finite number in {effect.unit}",
                                 line_of(text, where))
            theta[PARAM_INDEX[name]] = float(value)
    return SimTruth(theta, noise, lead)


def _is_number(value: object) -> bool:
    """A finite number (a nan or inf effect would crash the simulated gauges)."""
    return isinstance(value, int | float) and not isinstance(value, bool) and \
        math.isfinite(value)
