"""What a fit is fitted to: raw gauge readings, or deviations tabulated from them.

Both are linear combinations of the exact model's readings: raw readings each
carry their gauge's unknown zero (removed by projection), deviations are
differences in which the zeros cancel and whose errors are correlated through
the shared Zero readings (eq. 13-14 of the 2008 paper: covariance ``sigma^2 D D'``).
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:  # numpy.typing: 1 ms of start-up for annotations only
    from numpy.typing import ArrayLike

from ogacq.model.gauges import Gauge
from ogacq.model.machine import MachineSpec
from ogacq.model.measurement import (
    POSTURE_NAMES,
    ReadingsLayout,
    predict_and_jacobian,
    predict_coordinates,
)
from ogacq.model.parameters import AXES

DEVIATION_NAME = re.compile(r"^d([xyz])_([xyz])([+-]?)$")
POSTURE_OF_SIGN = {"+": "max", "-": "min", "": "max-min"}
# a deviation by its sign: the posture whose mean it is, and the one it is taken from
POSTURES_OF_SIGN = {"+": ("max", "zero"), "-": ("min", "zero"), "": ("max", "min")}
FORMS = {"12": ("+", "-"), "6": ("",)}  # the papers' two sets of deviations, by their signs


@dataclass(frozen=True)
class Deviation:
    """A tabulated deviation's name: ``dy_x+`` is gauge y_x at Max relative to Zero,
    ``dy_x-`` at Min, ``dy_x`` Max minus Min."""

    gauge: Gauge
    sign: str  # "+", "-" or ""

    @classmethod
    def parse(cls, name: str) -> Deviation:
        m = DEVIATION_NAME.match(name)
        if not m or m.group(1) == m.group(2):
            raise ValueError(f"{name!r} is not a deviation name like dx_y+, dx_y- or dx_y")
        return cls(Gauge(m.group(1), m.group(2)), m.group(3))

    @property
    def name(self) -> str:
        return f"d{self.gauge.key}{self.sign}"

    @property
    def posture(self) -> str:
        return POSTURE_OF_SIGN[self.sign]


# The order of eq. 11 of the 2008 paper, per leg pair (dX_Y+, dY_X+, dX_Y-, dY_X-).
PAPER_ORDER_12 = ("dx_y+", "dy_x+", "dx_y-", "dy_x-", "dx_z+", "dz_x+", "dx_z-", "dz_x-",
                  "dy_z+", "dz_y+", "dy_z-", "dz_y-")


@dataclass
class Observations:
    """Observed values ``y = D h(theta) + zeros + noise``: ``combination`` is D (None:
    the readings themselves, each gauge with its own unknown zero); ``noise_cov`` the
    noise covariance of ``y`` in units of the gauge variance ``sigma^2``."""

    machine: MachineSpec
    layout: ReadingsLayout
    values: np.ndarray
    labels: list[str]
    combination: np.ndarray | None = None
    source: str = ""
    kind: str = "readings"  # "readings" or "deviations"
    # (n,) how many gauge values each raw reading is the mean of, 0 where not recorded
    # (a session's ``averaged``); None: not known for any (``noise_averaged.py``)
    averaged: np.ndarray | None = field(default=None, compare=False, repr=False)
    # (n,) the sample standard deviation of those values (mm), NaN where not recorded
    averaged_sd_mm: np.ndarray | None = field(default=None, compare=False, repr=False)
    noise_cov: np.ndarray = field(init=False)
    # what is computed from these observations and reused (their noise, their
    # weighting's groups), each kept with the inputs it was computed from and
    # recomputed when one of them changed (``noise.noise_for``, ``fit.Weighting``)
    derived: dict = field(init=False, repr=False, compare=False, default_factory=dict)

    def __post_init__(self) -> None:
        self.values = np.asarray(self.values, dtype=float)
        if self.combination is None:
            self.noise_cov = np.eye(0)  # identity, never formed (campaigns can be long)
        else:
            self.noise_cov = self.combination @ self.combination.T

    @property
    def raw(self) -> bool:
        return self.combination is None

    def __len__(self) -> int:
        return len(self.values)

    def kept(self, keep: np.ndarray) -> Observations:
        """The observations the boolean mask ``keep`` selects; raw readings keep each
        gauge set where it was (``ReadingsLayout.subset``), deviations their layout."""
        if self.combination is None:
            return readings_observations(
                self.machine, self.layout.subset(keep), self.values[keep], self.source,
                None if self.averaged is None else self.averaged[keep],
                None if self.averaged_sd_mm is None else self.averaged_sd_mm[keep])
        return Observations(self.machine, self.layout, self.values[keep],
                            [lab for lab, k in zip(self.labels, keep, strict=True) if k],
                            self.combination[keep], self.source, self.kind)

    @property
    def n_nuisance(self) -> int:
        """Unknown gauge zeros fitted alongside the parameters."""
        return self.layout.n_gauges if self.raw else 0

    def predict(self, theta: np.ndarray) -> np.ndarray:
        """(B, m) or (m,) predicted observations, gauge zeros left out."""
        h = predict_coordinates(theta, self.layout, self.machine)
        return h if self.combination is None else h @ self.combination.T

    def jacobian(self, theta: np.ndarray, free: np.ndarray) -> np.ndarray:
        """(B, m, p) derivatives of :meth:`predict` by the parameters at ``free``,
        for theta (B, N): the model's analytic ones, combined like the values."""
        return self.predict_and_jacobian(theta, free)[1]

    def predict_and_jacobian(self, theta: np.ndarray, free: np.ndarray,
                             ) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`predict` (B, m) and :meth:`jacobian` (B, m, p) from one evaluation."""
        h, jac = predict_and_jacobian(theta, self.layout, self.machine, free)
        if self.combination is None:
            return h, jac
        return h @ self.combination.T, np.einsum("mn,bnp->bmp", self.combination, jac)

    def remove_zeros(self, x: np.ndarray) -> np.ndarray:
        """Project out what gauge zeros can absorb: per-gauge means for raw readings."""
        if not self.raw:
            return x
        onehot = self.layout.gauge_onehot  # (m, G)
        means = (x @ onehot) / self.layout.gauge_counts
        return x - means @ onehot.T


def readings_observations(machine: MachineSpec, layout: ReadingsLayout, values: ArrayLike,
                          source: str = "", averaged: np.ndarray | None = None,
                          averaged_sd_mm: np.ndarray | None = None) -> Observations:
    names = layout.gauge_names()
    labels = [f"{names[g]}@{k + 1}" for k, g in enumerate(layout.gauge.tolist())]
    return Observations(machine, layout, np.asarray(values, dtype=float), labels, None, source,
                        "readings", averaged, averaged_sd_mm)


# the per-reading arrays of a ReadingsLayout, concatenated as they are across sessions
_PER_READING = ("q_mm", "leg", "gauge_axis", "t_s", "cycle", "tcp_mm", "approach")


def readings_together(parts: Sequence[Observations], source: str = "") -> Observations:
    """The raw readings of several sessions of one machine fitted as one: each part's
    gauges keep their own unknown zeros (a gauge set again is another zero), its
    joint coordinates are as given (already in one frame: ``ogacq.calibration.
    together``). Repeats are grouped within a part only, a gauge being its part's."""
    if not parts or any(not p.raw for p in parts):
        raise ValueError("only raw readings are fitted together (deviations are one "
                         "session's)")
    layouts = [p.layout for p in parts]
    first_gauge = np.cumsum([0] + [lay.n_gauges for lay in layouts[:-1]])
    postures = [lay.posture for lay in layouts]
    layout = ReadingsLayout(
        **{name: np.concatenate([getattr(lay, name) for lay in layouts])
           for name in _PER_READING},
        gauge=np.concatenate([lay.gauge + g for lay, g in zip(layouts, first_gauge,
                                                               strict=True)]),
        gauge_keys=tuple(k for lay in layouts for k in lay.gauge_keys),
        setting_q_mm=np.concatenate([lay.setting_q_mm for lay in layouts]),
        posture=None if any(p is None for p in postures)
        else np.concatenate([p for p in postures if p is not None]))
    return readings_observations(parts[0].machine, layout,
                                 np.concatenate([p.values for p in parts]), source,
                                 *_averaged_together(parts))


def _averaged_together(parts: Sequence[Observations],
                       ) -> tuple[np.ndarray | None, np.ndarray | None]:
    """What each reading of the parts averaged and its scatter, where every part knows."""
    averaged = [p.averaged for p in parts]
    spread = [p.averaged_sd_mm for p in parts]
    if any(a is None for a in averaged) or any(s is None for s in spread):
        return None, None
    return (np.concatenate([a for a in averaged if a is not None]),
            np.concatenate([s for s in spread if s is not None]))


def deviations_observations(machine: MachineSpec, named: Sequence[tuple[str, float]],
                            source: str = "") -> Observations:
    """Deviations ``dX_Y+``/``dX_Y-`` (relative to Zero) or ``dX_Y`` (Max minus Min),
    laid out as one cycle of the papers' plan for the gauges named; approach and time
    unknown for tabulated data, taken as neutral."""
    # here: the protocol's dataclasses are 3 ms of a readings refit's start-up
    from ogacq.protocol.plan import ProtocolConfig, planned_layout

    parsed = [Deviation.parse(name) for name, _ in named]
    gauges = {d.gauge.indices for d in parsed}
    legs = tuple(leg for leg in AXES if any(d.gauge.leg == leg for d in parsed))
    plan = planned_layout(ProtocolConfig(legs=legs, postures=POSTURE_NAMES, cycles=1), machine,
                          seconds_per_posture=0.0)
    plan = plan.subset(np.array([(int(j), int(i)) in gauges
                                 for j, i in zip(plan.gauge_axis, plan.leg, strict=True)]))
    layout = ReadingsLayout.build(plan.q_mm, plan.leg, plan.gauge_axis, plan.t_s, plan.cycle,
                                  plan.tcp_mm, np.zeros_like(plan.approach), plan.posture)
    assert layout.posture is not None  # built with the plan's labels
    index = {(Gauge.at(j, i), posture): k for k, (j, i, posture) in
             enumerate(zip(layout.gauge_axis, layout.leg, layout.posture, strict=True))}
    D = np.zeros((len(parsed), len(layout)))
    for row, d in enumerate(parsed):
        first, second = POSTURES_OF_SIGN[d.sign]
        D[row, index[(d.gauge, first)]] = 1.0
        D[row, index[(d.gauge, second)]] = -1.0
    labels = [name for name, _ in named]
    return Observations(machine, layout, np.array([value for _, value in named]), labels, D,
                        source, "deviations")


def deviation_readings(obs: Observations, form: str = "12",
                       ) -> list[tuple[str, np.ndarray, np.ndarray]]:
    """The papers' deviations raw readings form (``form`` "12": Max and Min relative to
    Zero; "6": Max minus Min), gauge by gauge: each one's name (``dX_Y+``), the readings
    (boolean masks) whose mean it is and those whose mean it is taken from."""
    lay = obs.layout
    postures = lay.posture_names(obs.machine)
    out = []
    for j, i in lay.gauge_keys:
        sel = (lay.gauge_axis == j) & (lay.leg == i)
        at = {p: hit for p in POSTURE_NAMES if (hit := sel & (postures == p)).any()}
        out += [(f"d{AXES[j]}_{AXES[i]}{sign}", at[of], at[base])
                for sign, (of, base) in POSTURES_OF_SIGN.items()
                if sign in FORMS.get(form, ()) and of in at and base in at]
    if not out:
        raise ValueError("these readings hold no Zero/Max/Min postures to form deviations from")
    return out


def averaged_deviations(obs: Observations, form: str = "12") -> Observations:
    """The papers' deviations from raw readings: Max/Min relative to Zero, each
    averaged over cycles (``form`` "12"), or Max minus Min (``form`` "6")."""
    if not obs.raw:
        return obs
    named = [(name, float(obs.values[of].mean()) - float(obs.values[base].mean()))
             for name, of, base in deviation_readings(obs, form)]
    return deviations_observations(obs.machine, named, obs.source)
