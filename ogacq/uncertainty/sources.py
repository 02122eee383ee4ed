"""The sources of uncertainty, each modelled as what a unit of its input does to the
observations, so that one linear operator (the fit's solution operator, or the
deviations' averaging) carries every source to every output the same way
(JCGM 100:2008 clauses):

- gauge noise: each reading's scatter, normal, independent; type A when measured
  from the repeats (4.2.2, dof n - groups), type B when stated (4.3.1).
- display resolution: rectangular, ``u = s/sqrt(12)`` (4.3.7, F.2.2.1); repeats
  share the part the scatter does not dither (``identify/noise.py``: ``c(sigma,
  s)``; F.2.2.1's "the same reading" case).
- gauge calibration: the certificate's ``U_cert / k`` as a scale error of that gauge
  over the span it measured (4.3.3), ``e_g (x - x_set) / span_g``: fully correlated
  over its readings (5.2), independent between gauges; its constant part goes into
  the gauge's zero.
- temperature: the legs' ``alpha L (T - 20 degC)`` (ISO 1), the same for the three
  legs, ``T`` rectangular over the range seen (4.3.7) plus the thermometer's u
  (4.3.3), through the model's derivative by the leg lengths. Its mean is a known
  systematic effect (3.2.3, 3.2.4): stated as a correction, not hidden in u.
- register rounding: an offset stored in steps, ``u = step/sqrt(12)`` (4.3.7),
  sensitivity 1."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ogacq.identify.noise import shared_rounding_variance
from ogacq.identify.observations import Observations
from ogacq.model.machine import REFERENCE_TEMPERATURE_C
from ogacq.model.parameters import AXES, indices
from ogacq.uncertainty.inputs import BudgetInputs

INFINITE_DOF = math.inf
LEG_LENGTHS = tuple(f"leg_length.{a}" for a in AXES)


@dataclass(frozen=True)
class Source:
    """One input quantity and how a unit of it moves the observations.

    Exactly one of ``readings`` (a per-reading error: its correlation between
    repeats is ``shared``), ``vector`` (a systematic error: observation change per
    unit input) or ``direct`` (acts on the outputs themselves) is set."""

    name: str
    gum_type: str  # "A" or "B"
    distribution: str  # "normal" or "rectangular"
    unit: str  # of the input
    u_input: float | None  # None: not evaluated
    dof: float = INFINITE_DOF
    note: str = ""
    readings: bool = False
    shared: float = 0.0  # correlation of this error between repeats of one posture
    vector: np.ndarray | None = None  # (m,) per unit input
    direct: str | None = None  # "joint offsets": sensitivity 1 on joint offsets

    @property
    def evaluated(self) -> bool:
        return self.u_input is not None


class ObservationSpace:
    """What the sources act on: the observations ``y = L x`` of layout readings ``x``
    (``L`` the identity for raw readings, the deviations' combination otherwise)."""

    def __init__(self, obs: Observations) -> None:
        self.obs = obs
        self.groups = obs.layout.repeat_group
        self.n_groups = int(self.groups.max()) + 1 if len(self.groups) else 0

    def to_layout(self, operator: np.ndarray) -> np.ndarray:
        """``operator @ L``: (q, m) on observations -> (q, n) on layout readings."""
        c = self.obs.combination
        return operator if c is None else operator @ c

    def reading_spread(self, operator: np.ndarray, shared: float) -> np.ndarray:
        """(q,) standard deviation of ``operator @ y`` per unit reading error whose
        correlation between repeats is ``shared``: ``(1 - r) sum a^2 + r sum_g (sum a)^2``."""
        a = self.to_layout(operator)
        independent = np.sum(a**2, axis=1)
        per_group = np.zeros((a.shape[0], self.n_groups))
        np.add.at(per_group.T, self.groups, a.T)
        variance = (1.0 - shared) * independent + shared * np.sum(per_group**2, axis=1)
        return np.sqrt(np.maximum(variance, 0.0))


def gauge_noise(inputs: BudgetInputs) -> Source:
    if inputs.gauge_noise_mm is None:
        return Source("gauge noise", "A", "normal", "mm", None, readings=True,
                      note="not measured (no repeats) nor stated in the machine file")
    if inputs.gauge_noise_dof is not None:
        return Source("gauge noise", "A", "normal", "mm", inputs.gauge_noise_mm,
                      float(inputs.gauge_noise_dof), readings=True,
                      note=f"scatter of the repeated readings, {inputs.gauge_noise_dof} dof")
    return Source("gauge noise", "B", "normal", "mm", inputs.gauge_noise_mm, readings=True,
                  note="stated gauge repeatability")


def rounding_shared(obs: Observations, inputs: BudgetInputs) -> float:
    """Correlation of the display rounding between repeats of one posture."""
    step = inputs.resolution_mm
    if not obs.raw or step is None:
        return 0.0
    # An unknown scatter is taken as none: the repeats then read the same, the
    # rounding is fully shared and never averages out (the larger u of a mean).
    sigma = inputs.gauge_noise_mm or 0.0
    return min(shared_rounding_variance(sigma, step) / (step**2 / 12.0), 1.0)


def display_resolution(obs: Observations, inputs: BudgetInputs) -> Source:
    step = inputs.resolution_mm
    if step is None:
        return Source("display resolution", "B", "rectangular", "mm", None, readings=True,
                      note="display step not stated")
    shared = rounding_shared(obs, inputs)
    note = f"step {step:g} mm, half-width {step / 2:g} mm"
    if shared > 0.05:
        note += f"; repeats share {shared:.0%} of it"
    return Source("display resolution", "B", "rectangular", "mm", step / math.sqrt(12.0),
                  readings=True, shared=shared, note=note)


def calibration_span(obs: Observations, gauge: int) -> tuple[np.ndarray, float]:
    """(m,) each observation's displacement from the gauge's setting reading over the
    span that gauge measured (zero off that gauge), and the span in mm."""
    lay = obs.layout
    if obs.raw:
        mine = lay.gauge == gauge
        values = obs.values[mine]
        relative = np.zeros(len(obs))
        relative[mine] = values - values[0]  # gauges are set at their first reading
        span = float(values.max() - values.min())
    else:
        # a deviation is a difference of two readings of one gauge: its scale error
        # is the gauge's times the deviation itself
        combination = obs.combination
        assert combination is not None
        mine = np.any(combination[:, lay.gauge == gauge] != 0, axis=1)
        relative = np.where(mine, obs.values, 0.0)
        seen = np.concatenate([[0.0], obs.values[mine]])
        span = float(seen.max() - seen.min())
    return (relative / span if span > 0 else np.zeros(len(obs))), span


def gauge_calibrations(obs: Observations, inputs: BudgetInputs) -> list[Source]:
    out = []
    for g, key in enumerate(obs.layout.gauge_names()):
        vector, span = calibration_span(obs, g)
        u = inputs.calibration_u_mm.get(key)
        note = f"scale error over the {span:.4g} mm span this gauge measured"
        if u is None:
            note = "no certificate: " + note
        out.append(Source(f"gauge calibration {key}", "B", "normal", "mm", u, vector=vector,
                          note=note))
    return out


def thermal_vector(obs: Observations, theta: np.ndarray, inputs: BudgetInputs) -> np.ndarray:
    """(m,) change of the observations referred to 20 degC per degC of the legs'
    temperature: ``-alpha L`` times the derivative by a common leg length change."""
    jac = obs.predict_and_jacobian(theta[None], indices(LEG_LENGTHS))[1][0]
    alpha_l = inputs.alpha_l_mm_per_k or 0.0
    return -alpha_l * jac.sum(axis=1)


def temperature(obs: Observations, theta: np.ndarray, inputs: BudgetInputs) -> list[Source]:
    vector = thermal_vector(obs, theta, inputs)
    coefficient, ambient = inputs.leg_expansion_ppm_per_k, inputs.ambient_range_c
    if coefficient is None:
        missing = "legs' expansion coefficient not stated"
    elif ambient is None:
        which = [stage for stage, t in (("start", inputs.ambient_start_c),
                                        ("end", inputs.ambient_end_c)) if t is None]
        missing = f"temperature at {' and '.join(which)} not recorded"
    else:
        missing = ""
    legs = (f"legs {coefficient:g} ppm/K x {inputs.leg_length_mm:g} mm" if coefficient
            is not None else "legs")
    if missing or ambient is None:
        return [Source("temperature range", "B", "rectangular", "degC", None, vector=vector,
                       note=missing),
                Source("thermometer", "B", "normal", "degC", None, vector=vector,
                       note=missing)]
    low, high = ambient
    return [Source("temperature range", "B", "rectangular", "degC",
                   (high - low) / math.sqrt(12.0), vector=vector,
                   note=f"{low:g}..{high:g} degC during the campaign; {legs}"),
            Source("thermometer", "B", "normal", "degC", inputs.thermometer_u_c,
                   vector=vector, note=f"thermometer u {inputs.thermometer_u_c:g} degC")]


def mean_temperature_offset(inputs: BudgetInputs) -> float | None:
    """``T_mean - 20``: the mean temperature's departure from the reference, degC."""
    if inputs.ambient_range_c is None or inputs.leg_expansion_ppm_per_k is None:
        return None
    low, high = inputs.ambient_range_c
    return 0.5 * (low + high) - REFERENCE_TEMPERATURE_C


def register_rounding(inputs: BudgetInputs) -> Source | None:
    """None when nothing is written: the identified value is not rounded."""
    step = inputs.register_step_mm
    if step is None:
        return None
    return Source("register rounding", "B", "rectangular", "mm", step / math.sqrt(12.0),
                  direct="joint offsets", note=f"offset register step {step:g} mm")
