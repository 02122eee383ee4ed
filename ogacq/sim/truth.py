"""The simulated machine's hidden truth: geometry, effects and gauge behaviour.

An effects file (TOML) names any entries of the INTERCHANGE.md vocabulary, one
table per effect, plus the gauges' noise and errors of the axes outside the effect
library (so that the diagnosis can be shown physics it does not know)::

    [joint_offset]        # mm
    x = 0.42
    [squareness]          # mrad
    xy = 0.5
    [gauges]
    noise_mm = 0.001
    [lead_screw.x]        # cyclic error of the x screw: A sin(2 pi q / pitch + phase)
    amplitude_mm = 0.005
    pitch_mm = 5.0
    phase_deg = 30.0      # optional, 0
    [screw_map.y]         # smooth error of the y screw: sum of c_k (q / 100 mm)^k, k = 1..
    coefficients_mm = [0.0, 0.0, 0.004]
    [rail_bow.z]          # the z rail bowed toward x by 8 um mid-travel
    toward = "x"
    sagitta_mm = 0.008
    [hysteresis.x]        # lost motion building up with the travel since a reversal
    lost_motion_mm = 0.02
    build_up_mm = 6.0     # the travel over which it builds up (e-folding length)
    [warm_up.y]           # the y joint offset settling while the machine warms up
    offset_mm = 0.01
    time_constant_s = 1800.0
    [vibration]           # the damped vibration after each move (amplitude_mm = 0: none)
    amplitude_mm = 0.01
    time_constant_s = 0.15
    frequency_hz = 20.0

Each axis error is the displacement of its joint, actual minus commanded, with the
sign and shape of ``ogacq/model/families/``'s families (which the diagnosis fits), each
written here again on its own so that the diagnosis is checked against independent
physics: the along-the-line errors added to the commanded ``q`` before the exact
model, the bow moving the joint centre across its line. A family registered later (a
plugin's, a test's) is simulated by its own shape: ``SimTruth.map_terms``, a term with
its amplitudes.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from ogacq_drivers.config_schema import Field, ListOf, MapOf, Table, load, number, text
from ogacq.errors import InputError
from ogacq.io.text import read_text
from ogacq.io.toml_file import load_toml, parse_toml_text
from ogacq.model.families import MapTerm
from ogacq.model.machine import MachineSpec
from ogacq.model.parameters import AXES, EFFECTS, PARAM_INDEX, vector

# The polynomial screw map's unit of q: its coefficients are the error at q = 100 mm.
SCREW_MAP_UNIT_MM = 100.0


@dataclass(frozen=True)
class LeadScrewError:
    amplitude_mm: float
    pitch_mm: float
    phase_deg: float = 0.0

    def error_mm(self, q: np.ndarray) -> np.ndarray:
        return self.amplitude_mm * np.sin(2 * np.pi * q / self.pitch_mm
                                          + np.deg2rad(self.phase_deg))


@dataclass(frozen=True)
class ScrewMap:
    """A smooth screw error ``sum_k c_k (q / 100 mm)^k``, k from 1 (the constant is
    a joint offset)."""

    coefficients_mm: tuple[float, ...]

    def error_mm(self, q: np.ndarray) -> np.ndarray:
        x = np.asarray(q, dtype=float) / SCREW_MAP_UNIT_MM
        return sum((c * x ** (k + 1) for k, c in enumerate(self.coefficients_mm)),
                   np.zeros_like(x))


@dataclass(frozen=True)
class RailBow:
    """The rail bowed toward world axis ``toward``: the joint centre moves across its
    line by ``sagitta_mm (1 - xi^2)``, xi running from -1 at ``from_mm`` to 1 at
    ``to_mm`` (the machine's travel when not given)."""

    toward: str
    sagitta_mm: float
    from_mm: float | None = None
    to_mm: float | None = None

    def span(self, machine: MachineSpec) -> tuple[float, float]:
        return (machine.rho_min_mm if self.from_mm is None else self.from_mm,
                machine.rho_max_mm if self.to_mm is None else self.to_mm)

    def across_mm(self, q: np.ndarray, machine: MachineSpec) -> np.ndarray:
        lo, hi = self.span(machine)
        xi = (2.0 * np.asarray(q, dtype=float) - (lo + hi)) / (hi - lo)
        return self.sagitta_mm * (1.0 - xi**2)


@dataclass(frozen=True)
class Hysteresis:
    """Lost motion that builds up with the travel ``s`` since the last reversal: the
    joint lags its direction of motion by ``lost_motion_mm / 2 (1 - 2 exp(-s /
    build_up_mm))`` after a full reversal (first-order wind-up, Dahl 1968); a
    constant backlash when ``build_up_mm`` is 0."""

    lost_motion_mm: float
    build_up_mm: float

    def error_mm(self, side: np.ndarray, travel_mm: np.ndarray) -> np.ndarray:
        side = np.asarray(side, dtype=float)
        if self.build_up_mm <= 0:
            wound = np.ones_like(side)
        else:
            with np.errstate(over="ignore"):
                wound = 1.0 - 2.0 * np.exp(-np.asarray(travel_mm, float) / self.build_up_mm)
        return -side * self.lost_motion_mm / 2.0 * wound


@dataclass(frozen=True)
class WarmUp:
    """The joint offset grows by ``offset_mm (1 - exp(-t / time_constant_s))``."""

    offset_mm: float
    time_constant_s: float

    def error_mm(self, t_s: np.ndarray) -> np.ndarray:
        return self.offset_mm * (1.0 - np.exp(-np.asarray(t_s, float) / self.time_constant_s))


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

    def mean_mm(self, share: float, phase: float, from_s: float, to_s: float) -> float:
        """The mean over ``from_s``..``to_s`` after a stop of the ringing of amplitude
        ``share`` x ``amplitude_mm`` and ``phase`` (its value at ``to_s`` where the span
        is nil; scalars in ``math``: it runs at every simulated gauge value): the
        integral of ``exp(-a t) sin(w t + phase)`` is ``exp(-a t) (-a sin(w t + phase)
        - w cos(w t + phase)) / (a^2 + w^2)``."""
        a, w = 1.0 / self.time_constant_s, 2 * math.pi * self.frequency_hz
        amplitude = share * self.amplitude_mm
        if to_s - from_s < 1e-9:
            return amplitude * math.exp(-a * to_s) * math.sin(w * to_s + phase)

        def primitive(t: float) -> float:
            return math.exp(-a * t) * (-a * math.sin(w * t + phase)
                                       - w * math.cos(w * t + phase)) / (a * a + w * w)

        return amplitude * (primitive(to_s) - primitive(from_s)) / (to_s - from_s)


@dataclass
class SimTruth:
    theta: np.ndarray  # full parameter vector (ogacq.model.parameters order)
    noise_mm: float = 0.001
    lead_screw: dict[int, LeadScrewError] = field(default_factory=dict)
    vibration: Vibration = field(default_factory=Vibration)
    screw_map: dict[int, ScrewMap] = field(default_factory=dict)
    rail_bow: dict[int, RailBow] = field(default_factory=dict)
    hysteresis: dict[int, Hysteresis] = field(default_factory=dict)
    warm_up: dict[int, WarmUp] = field(default_factory=dict)
    # along-the-line errors of any family, by its own shape (MapTerm.shape_of) times
    # its amplitudes
    map_terms: tuple[tuple[MapTerm, tuple[float, ...]], ...] = ()

    def __post_init__(self) -> None:
        for term, _ in self.map_terms:
            if not term.along:
                raise ValueError(f"{term.name}: only errors along a joint's line are "
                                 "simulated by their shape")

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
        return replace(self, theta=theta)

    @property
    def has_axis_errors(self) -> bool:
        return bool(self.lead_screw or self.screw_map or self.rail_bow or self.hysteresis
                    or self.warm_up or self.map_terms)

    def disturbed_q(self, q_mm: np.ndarray, side: np.ndarray | None = None,
                    travel_mm: np.ndarray | None = None,
                    t_s: np.ndarray | float | None = None) -> np.ndarray:
        """Joint coordinates as the physics sees them (..., 3): every error along the
        joints' lines added to the commanded ``q``. ``side`` (..., 3) the direction of
        each joint's last move, ``travel_mm`` its travel since its last reversal
        (None: unknown, taken as long), ``t_s`` the time (for the warm-up); without
        ``side`` the hysteresis is left out (a gauge's setting, whose side the
        simulator does not follow)."""
        out = np.array(q_mm, dtype=float)
        q = np.array(q_mm, dtype=float)
        for axis, err in self.lead_screw.items():
            out[..., axis] += err.error_mm(q[..., axis])
        for axis, smooth in self.screw_map.items():
            out[..., axis] += smooth.error_mm(q[..., axis])
        if side is not None:
            side = np.asarray(side)
            travel = np.full(np.shape(side), np.inf) if travel_mm is None \
                else np.asarray(travel_mm)
            for axis, lag in self.hysteresis.items():
                out[..., axis] += lag.error_mm(side[..., axis], travel[..., axis])
        if t_s is not None:
            for axis, warm in self.warm_up.items():
                out[..., axis] += warm.error_mm(np.asarray(t_s))
        for term, amplitudes in self.map_terms:
            out[..., term.axis] += _term_error_mm(term, amplitudes, q[..., term.axis],
                                                  side, travel_mm, t_s)
        return out

    def across_mm(self, q_mm: np.ndarray, machine: MachineSpec) -> np.ndarray:
        """(..., 3, 3) each joint centre's displacement across its line [joint, world
        coordinate] from the rails' bows."""
        q = np.asarray(q_mm, dtype=float)
        out = np.zeros(q.shape + (3,))
        for axis, bow in self.rail_bow.items():
            out[..., axis, AXES.index(bow.toward)] += bow.across_mm(q[..., axis], machine)
        return out


def _term_error_mm(term: MapTerm, amplitudes: tuple[float, ...], q: np.ndarray,
                   side: np.ndarray | None, travel_mm: np.ndarray | None,
                   t_s: np.ndarray | float | None) -> np.ndarray:
    """A term's displacement at ``q`` (any shape); an unknown side taken as forward
    and an unknown travel as long, as a table is read, and no time as t = 0."""
    a, shape = term.axis, np.shape(q)

    def flat(values: np.ndarray | float | None, default: float) -> np.ndarray:
        given = default if values is None else values
        return np.broadcast_to(np.asarray(given, dtype=float), shape).ravel()

    along = term.shape_of(np.ravel(q), flat(None if side is None else side[..., a], 1.0),
                          flat(None if travel_mm is None else travel_mm[..., a], np.inf),
                          flat(t_s, 0.0))
    return (np.asarray(amplitudes, dtype=float) @ along).reshape(shape)


def random_truth(seed: int, offsets_mm: float = 1.5, noise_mm: float = 0.001) -> SimTruth:
    """Hidden joint offsets drawn from the seed, everything else nominal."""
    rng = np.random.default_rng(seed)
    values = {f"joint_offset.{a}": float(v)
              for a, v in zip(AXES, rng.uniform(-offsets_mm, offsets_mm, 3), strict=True)}
    return SimTruth(vector(values), noise_mm)


def _per_axis(fields: tuple[Field, ...], build: Callable[..., Any]) -> MapOf:
    return MapOf(Table(fields, build=build), keys=AXES, noun="axis")


# The effects file's schema: one table per effect of the vocabulary, its entries
# in the effect's unit within its plausible range about nominal (the effects table,
# ogacq/model/parameters.py: a machine beyond it is not one to simulate); the
# gauges' noise; the axes' errors outside the library. The other maxima are an order
# of magnitude beyond a real machine's (no source).
# A screw's cyclic error repeats every lead: no screw that drives an axis has a lead
# under a tenth of a millimetre (ISO 261's finest metric pitch is 0.2 mm), and a shorter
# "pitch" is not a screw but noise folded onto the postures (1e-9 mm was accepted).
MIN_SCREW_PITCH_MM = 0.1
EFFECTS_FILE = Table((
    *(Field(e.name, MapOf(number(minimum=e.nominal - e.plausible_range,
                                 maximum=e.nominal + e.plausible_range, unit=e.unit),
                          keys=e.wheres, noun="entry"))
      for e in EFFECTS),
    Field("gauges", Table((Field("noise_mm", number(minimum=0.0, maximum=1.0)),))),
    Field("lead_screw", _per_axis((
        Field("amplitude_mm", number(minimum=-1.0, maximum=1.0), required=True),
        Field("pitch_mm", number(minimum=MIN_SCREW_PITCH_MM, maximum=1000.0), required=True),
        Field("phase_deg", number(minimum=-360.0, maximum=360.0)),
    ), LeadScrewError)),
    Field("screw_map", _per_axis((
        Field("coefficients_mm", ListOf(number(minimum=-1.0, maximum=1.0)), required=True,
              decode=tuple),
    ), ScrewMap)),
    Field("rail_bow", _per_axis((
        Field("toward", text(*AXES), required=True),
        Field("sagitta_mm", number(minimum=-1.0, maximum=1.0), required=True),
        Field("from_mm", number(minimum=-1000.0, maximum=1000.0)),
        Field("to_mm", number(minimum=-1000.0, maximum=1000.0)),
    ), RailBow)),
    Field("hysteresis", _per_axis((
        Field("lost_motion_mm", number(minimum=0.0, maximum=1.0), required=True),
        Field("build_up_mm", number(minimum=0.0, maximum=1000.0), required=True),
    ), Hysteresis)),
    Field("warm_up", _per_axis((
        Field("offset_mm", number(minimum=-1.0, maximum=1.0), required=True),
        Field("time_constant_s", number(positive=True, maximum=1e6), required=True),
    ), WarmUp)),
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
    return _with_effects(given, base, path)


def effects_from_text(text: str, path: str | Path, base: SimTruth) -> SimTruth:
    """As :func:`read_effects`, of the text read before from ``path`` (checked before it
    is copied anywhere; a pipe can be read only once), its errors naming ``path``."""
    data, source = parse_toml_text(text, path, "the effects file")
    return _with_effects(load(EFFECTS_FILE, data, source), base, path)


def read_effects_text(path: Path) -> str:
    """The effects file's text, read once (a pipe such as ``<(...)`` can be read only
    once) and checked before the caller copies it into a run's folder: a copy that does
    not load would name the copy, and stop every resume of the run."""
    try:
        text = read_text(path)
    except OSError as exc:
        raise InputError(path, f"cannot read the effects file ({exc.strerror or exc})") from None
    effects_from_text(text, path, random_truth(0))  # InputError naming the file and line
    return text


def _with_effects(given: dict[str, Any], base: SimTruth, path: str | Path) -> SimTruth:
    theta = base.theta.copy()
    for effect in EFFECTS:
        for where, value in given.get(effect.name, {}).items():
            theta[PARAM_INDEX[f"{effect.name}.{where}"]] = value
    noise = given.get("gauges", {}).get("noise_mm", base.noise_mm)

    def axes(key: str, known: dict) -> dict:
        return {**known, **{AXES.index(axis): v for axis, v in given.get(key, {}).items()}}

    bows = axes("rail_bow", base.rail_bow)
    for axis, bow in bows.items():
        if bow.toward == AXES[axis]:
            raise InputError(path, f"rail_bow.{AXES[axis]}.toward must be another axis than "
                                   f"{AXES[axis]} (a bow moves the joint across its line)")
    return SimTruth(theta, noise, axes("lead_screw", base.lead_screw),
                    given.get("vibration", base.vibration), axes("screw_map", base.screw_map),
                    bows, axes("hysteresis", base.hysteresis), axes("warm_up", base.warm_up),
                    base.map_terms)
