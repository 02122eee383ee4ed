"""Calibration of the consistency test itself: how often does it cry wolf?

Seeded control campaigns (joint offsets only: "consistent" expected), simulated
over the regimes a shop has, each cell's false-alarm rate beside the level with its
binomial 95 % interval; with a concealed effect, the test's power. Readings: the
exact model's, each gauge's random zero (the rounding's phase), Gaussian scatter,
the display's rounding. ``bench/verdict_calibration.py`` prints the grid; a test
runs a slice."""

from __future__ import annotations

import itertools
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, replace

import numpy as np
from scipy import stats

from ogacq.identify.consistency import LEVEL, fit_verdict
from ogacq.identify.fit import fit
from ogacq.identify.observations import Observations, readings_observations
from ogacq.model.machine import PAPER_PROTOTYPE_DIGITAL, MachineSpec
from ogacq.model.measurement import ReadingsLayout
from ogacq.model.parameters import PARAM_SETS, vector
from ogacq.model.units import UM_PER_MM
from ogacq.protocol.plan import ProtocolConfig, planned_layout

GEOMETRIES = {
    "prototype": PAPER_PROTOTYPE_DIGITAL,
    "large": MachineSpec(620.0, -220.0, 180.0, gauge_resolution_mm=0.001),
}
PROTOCOLS: dict[str, tuple[str | float, ...]] = {
    "papers": ("zero", "max", "min", "zero"),
    # intermediate postures, each approached from both sides
    "both-sides": ("zero", 30.0, "max", 30.0, "zero", -50.0, "min", -50.0, "zero"),
}
DISPLAYS_MM = (0.001, 0.01)
NOISES_MM = (0.0003, 0.001, 0.002, 0.005)
NOISE_SOURCES = ("declared", "repeats")
OFFSETS = {"joint_offset.x": 0.8, "joint_offset.y": -0.5, "joint_offset.z": 1.2}


@dataclass(frozen=True)
class Cell:
    display_mm: float
    noise_mm: float
    source: str  # "declared" (machine file) or "repeats"
    protocol: str
    geometry: str
    cycles: int = 3

    def machine(self) -> MachineSpec:
        base = GEOMETRIES[self.geometry]
        return replace(base, gauge_resolution_mm=self.display_mm,
                       gauge_repeatability_mm=self.noise_mm if self.source == "declared"
                       else None)

    def layout(self) -> ReadingsLayout:
        return planned_layout(ProtocolConfig(postures=PROTOCOLS[self.protocol],
                                             cycles=self.cycles), self.machine())

    def label(self) -> str:
        return (f"{self.display_mm * UM_PER_MM:>4g} µm  {self.noise_mm * UM_PER_MM:>4g} µm  "
                f"{self.source:<8}  {self.protocol:<10}  {self.geometry:<9}")


@dataclass(frozen=True)
class Rate:
    hits: int
    trials: int

    @property
    def value(self) -> float:
        return self.hits / self.trials if self.trials else float("nan")

    def interval(self, confidence: float = 0.95) -> tuple[float, float]:
        """Clopper-Pearson (exact binomial) interval."""
        a = 1.0 - confidence
        low = stats.beta.ppf(a / 2, self.hits, self.trials - self.hits + 1) if self.hits else 0.0
        high = (stats.beta.ppf(1 - a / 2, self.hits + 1, self.trials - self.hits)
                if self.hits < self.trials else 1.0)
        return float(low), float(high)


def grid(displays: Iterable[float] = DISPLAYS_MM, noises: Iterable[float] = NOISES_MM,
         sources: Iterable[str] = NOISE_SOURCES, protocols: Iterable[str] = PROTOCOLS,
         geometries: Iterable[str] = GEOMETRIES) -> list[Cell]:
    return [Cell(*c) for c in itertools.product(displays, noises, sources, protocols,
                                                geometries)]


def simulated_observations(cell: Cell, seed: int, effects: Mapping[str, float] | None = None,
                           lay: ReadingsLayout | None = None) -> Observations:
    machine = cell.machine()
    lay = lay if lay is not None else cell.layout()
    rng = np.random.default_rng(seed)
    clean = readings_observations(machine, lay, np.zeros(len(lay))).predict(
        vector({**OFFSETS, **(effects or {})}))
    zeros = rng.uniform(2.0, 10.0, lay.n_gauges)
    values = clean + zeros[lay.gauge] + rng.normal(0.0, cell.noise_mm, len(lay))
    step = cell.display_mm
    return readings_observations(machine, lay, np.round(values / step) * step)


def alarm_rate(cell: Cell, seeds: Sequence[int], effects: Mapping[str, float] | None = None,
               level: float = LEVEL) -> Rate:
    """How often the offsets-only fit is called inconsistent."""
    lay = cell.layout()
    hits = 0
    for seed in seeds:
        obs = simulated_observations(cell, seed, effects, lay)
        verdict = fit_verdict(fit(obs, PARAM_SETS["offsets"]), level)
        hits += verdict.state == "inconsistent"
    return Rate(hits, len(seeds))


def seeds_of(cell: Cell, count: int, first: int = 0) -> list[int]:
    """Distinct seeds per cell, the same on every run."""
    base = _stable_hash(cell.label())
    return [base * 1000 + first + k for k in range(count)]


def _stable_hash(text: str) -> int:
    return sum((k + 1) * ord(ch) for k, ch in enumerate(text)) % 100_003
