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
    [vibration]           # the damped vibration after each move (amplitude_mm = 0: none)
    amplitude_mm = 0.01
    time_constant_s = 0.15
    frequency_hz = 20.0
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ogacq_drivers.config_schema import Field, MapOf, Table, number
from ogacq.io.toml_file import load_toml
from ogacq.model.machine import MachineSpec
from ogacq.model.parameters import AXES, EFFECTS, PARAM_INDEX, vector


@dataclass(frozen=True)
class LeadScrewError:
    amplitude_mm: float
    pitch_mm: float


@dataclass(frozen=True)
class Vibration:
    """The machine rings after each move: every gauge sees a damped oscillation
    ``a exp(-t / time_constant_s) sin(2 pi frequency_hz t + phase)`` from the moment the
    last axis stops, ``a`` drawn per move and gauge (seeded) between half and all of
    ``amplitude_mm``, the phase uniform. The defaults are a frame mode of 20 Hz with
    about 5 % damping (time constant 1 / (zeta 2 pi f) = 0.16 s) ringing at 10 um after
    a 2 m/s^2 stop; no source, an order of magnitude for a light machine."""

    amplitude_mm: float = 0.01
    time_constant_s: float = 0.15
    frequency_hz: float = 20.0

    def envelope_mm(self, since_stop_s: float) -> float:
        """The largest vibration a gauge can show ``since_stop_s`` after a stop."""
        return self.amplitude_mm * float(np.exp(-max(since_stop_s, 0.0) / self.time_constant_s))


@dataclass
class SimTruth:
    theta: np.ndarray  # full parameter vector (ogacq.model.parameters order)
    noise_mm: float = 0.001
    lead_screw: dict[int, LeadScrewError] = field(default_factory=dict)
    vibration: Vibration = field(default_factory=Vibration)

    def hidden(self) -> dict[str, float]:
        """The non-nominal entries: what a calibration should find."""
        from ogacq.model.parameters import non_nominal

        return non_nominal(self.theta)

    def at_temperature(self, machine: MachineSpec, temperature_c: float) -> SimTruth:
        """This truth with the legs at ``temperature_c``: each leg alpha L (T - 20 degC)
        longer than at the reference temperature (ISO 1), on top of any leg-length
        error the effects give; alpha from the machine file (steel when not given)."""
        theta = self.theta.copy()
        for axis in AXES:
            theta[PARAM_INDEX[f"leg_length.{axis}"]] += machine.leg_expansion_mm(temperature_c)
        # the rest of the physics as it was (an effects file's [vibration] included)
        return SimTruth(theta, self.noise_mm, dict(self.lead_screw), self.vibration)

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


# The effects file's schema: one table per effect of the vocabulary, its entries
# in the effect's unit within its plausible range about nominal (the effects table,
# ogacq/model/parameters.py: a machine beyond it is not one to simulate); the
# gauges' noise; the out-of-library lead-screw error. The other maxima are an order
# of magnitude beyond a real machine's (no source).
EFFECTS_FILE = Table((
    *(Field(e.name, MapOf(number(minimum=e.nominal - e.plausible_range,
                                 maximum=e.nominal + e.plausible_range),
                          keys=e.wheres, noun="entry"))
      for e in EFFECTS),
    Field("gauges", Table((Field("noise_mm", number(minimum=0.0, maximum=1.0)),))),
    Field("lead_screw", MapOf(Table((
        Field("amplitude_mm", number(minimum=-1.0, maximum=1.0), required=True),
        Field("pitch_mm", number(positive=True, maximum=1000.0), required=True),
    ), build=LeadScrewError), keys=AXES, noun="axis")),
    Field("vibration", Table((
        Field("amplitude_mm", number(minimum=0.0, maximum=1.0)),
        Field("time_constant_s", number(positive=True, maximum=60.0)),
        Field("frequency_hz", number(positive=True, maximum=10_000.0)),
    ), build=Vibration)),
), noun="effect")


def read_effects(path: str | Path, base: SimTruth) -> SimTruth:
    """``base`` with the effects file's entries applied on top (a nan or inf effect
    would crash the simulated gauges: the schema refuses them)."""
    given, _ = load_toml(path, EFFECTS_FILE, "the effects file")
    theta = base.theta.copy()
    for effect in EFFECTS:
        for where, value in given.get(effect.name, {}).items():
            theta[PARAM_INDEX[f"{effect.name}.{where}"]] = value
    noise = given.get("gauges", {}).get("noise_mm", base.noise_mm)
    lead = {**base.lead_screw,
            **{AXES.index(axis): err for axis, err in given.get("lead_screw", {}).items()}}
    return SimTruth(theta, noise, lead, given.get("vibration", base.vibration))
