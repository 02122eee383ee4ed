"""What extra measurement would tell two aliased effects apart?

Each candidate plan (other postures, approach sides, a longer campaign) is laid out
with the exact model, and the expected chi-square by which the wrong one of the two
would fit worse is computed at the fitted values. A plan separates them when that
gap makes the wrong one fail the alternatives' three-sigma rule with 95 %
probability: sqrt(gap) - 1.645 * 2 >= 3 sigma of the rule, i.e. a gap of 26."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ogacq.diagnose.batchfit import Problem
from ogacq.diagnose.library import BASE_MODEL, EFFECT_PARAMETERS
from ogacq.diagnose.visibility import Capability, capability
from ogacq.identify.observations import readings_observations
from ogacq.model.machine import MachineSpec
from ogacq.protocol.plan import ProtocolConfig, planned_layout

SEPARATES_CHI2 = 26.0


@dataclass(frozen=True)
class PlanOption:
    key: str
    description: str
    postures: tuple[str | float, ...]
    cycles: int = 3
    seconds_per_posture: float = 20.0

    def postures_arg(self) -> str:
        return ",".join(p if isinstance(p, str) else f"{p:g}" for p in self.postures)

    def plan_command(self, machine_file: str = "M.toml") -> str:
        return (f"ogacq plan --machine {machine_file} --postures {self.postures_arg()} "
                f"--cycles {self.cycles}")


def plan_options(machine: MachineSpec) -> list[PlanOption]:
    """Candidate campaigns, cheapest first."""
    hi = float(round(machine.rho_max_mm / 2))
    lo = float(round(machine.rho_min_mm / 2))
    papers = ("zero", "max", "min", "zero")
    return [
        PlanOption("readings", "record the raw readings of the papers' protocol (Zero, Max, "
                   "Min, Zero, three cycles) with their times, not tabulated deviations",
                   papers),
        PlanOption("zero-both-sides", "return to Zero between Max and Min, so that Zero is "
                   "approached from both sides", ("zero", "max", "zero", "min", "zero")),
        PlanOption("intermediate", f"add intermediate postures at {hi:+g} and {lo:+g} mm "
                   "along each leg", ("zero", hi, "max", lo, "min", "zero")),
        PlanOption("both-sides", f"add intermediate postures at {hi:+g} and {lo:+g} mm, each "
                   "approached from both sides, and Zero from both sides",
                   ("zero", hi, "max", hi, "zero", lo, "min", lo, "zero")),
        PlanOption("slow", "spread the campaign in time: six cycles, a minute per posture",
                   papers, cycles=6, seconds_per_posture=60.0),
    ]


@dataclass(frozen=True)
class Separation:
    effect: str
    alternative: str
    now: float  # expected chi-square gap on the data at hand
    by_plan: tuple[tuple[PlanOption, float], ...]

    @property
    def separating(self) -> PlanOption | None:
        return next((p for p, gap in self.by_plan if gap >= SEPARATES_CHI2), None)

    def _other_kind(self) -> str:
        """A measurement outside the leg-observation campaign that settles it."""
        for name in (self.effect, self.alternative):
            effect, where = name.split(".")
            if effect in INSTRUMENT_CHECKS:
                return INSTRUMENT_CHECKS[effect].format(where=where)
        return "a measurement of another kind is needed"

    def describe(self) -> str:
        plan = self.separating
        if plan is None:
            best, gap = max(self.by_plan, key=lambda t: t[1])
            return (f"none of the plans tried separates {self.effect} from {self.alternative} "
                    f"(best: {best.key}, expected gap {gap:.1f}); {self._other_kind()}")
        gap = dict((p.key, g) for p, g in self.by_plan)[plan.key]
        return (f"to separate {self.effect} from {self.alternative}: {plan.description} "
                f"(expected chi-square gap {gap:.0f}, now {self.now:.1f}; check with "
                f"`{plan.plan_command()}`)")


def plan_problem(machine: MachineSpec, option: PlanOption) -> Problem:
    """The plan's readings laid out by the exact model (values are irrelevant)."""
    layout = planned_layout(ProtocolConfig(postures=tuple(option.postures),
                                           cycles=option.cycles), machine,
                            seconds_per_posture=option.seconds_per_posture)
    return Problem(readings_observations(machine, layout, np.zeros(len(layout))))


def plan_capabilities(machine: MachineSpec, theta: np.ndarray, sigma_mm: float,
                      ) -> list[tuple[PlanOption, Capability]]:
    """What each candidate plan could decide about the library, at ``theta``."""
    everything = BASE_MODEL + EFFECT_PARAMETERS
    out = []
    for option in plan_options(machine):
        plan = plan_problem(machine, option)
        out.append((option, capability(plan.jacobian(theta, everything), everything,
                                       sigma_mm, plan.n_data)))
    return out


INSTRUMENT_CHECKS = {
    "gauge_scale": "check the gain of gauge {where} against a gauge block",
    "gauge_position": "measure where the gauges touch leg {where}",
}


class PlanSignatures:
    """Weighted Jacobians of the candidate plans at one parameter vector, computed once
    and shared by every pair of aliases."""

    def __init__(self, machine: MachineSpec, theta: np.ndarray, names: tuple[str, ...],
                 current: Problem) -> None:
        self.names = names
        # Raw readings need no advice to record raw readings.
        self.options = [o for o in plan_options(machine)
                        if not (current.obs.raw and o.key == "readings")]
        self.current = current.jacobian(theta, names)
        self.plans = [plan_problem(machine, o).jacobian(theta, names) for o in self.options]

    def gap(self, jw: np.ndarray, signature_of: str, value: float, fitted: tuple[str, ...],
            sigma_mm: float) -> float:
        """Expected chi-square gap when ``signature_of`` at ``value`` is in the data but
        ``fitted`` (which lacks it) is fitted: the part of its signature the fitted
        model cannot absorb."""
        col = {n: k for k, n in enumerate(self.names)}
        s = jw[:, col[signature_of]] * value
        basis = jw[:, [col[n] for n in fitted]]
        coef, *_ = np.linalg.lstsq(basis, s, rcond=None)
        return float(np.sum((s - basis @ coef) ** 2) / sigma_mm**2)


def separation(signatures: PlanSignatures, model: tuple[str, ...], effect: str,
               effect_value: float, alternative: str, alternative_value: float,
               sigma_mm: float) -> Separation:
    """How well each plan would separate ``effect`` (in ``model``) from ``alternative``.
    Both ways: whichever of the two is true, the other must fit worse."""
    swapped = tuple(alternative if n == effect else n for n in model)

    def gap(jw: np.ndarray) -> float:
        return min(signatures.gap(jw, effect, effect_value, swapped, sigma_mm),
                   signatures.gap(jw, alternative, alternative_value, model, sigma_mm))

    return Separation(effect, alternative, gap(signatures.current),
                      tuple((o, gap(jw)) for o, jw in zip(signatures.options,
                                                          signatures.plans, strict=True)))
