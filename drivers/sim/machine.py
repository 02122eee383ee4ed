"""The simulated machine: physics shared by the simulated controller and gauges.

The motion model knows where each actuator's encoder is; this module turns that
into what a gauge set on a leg reads, through the same exact measurement model
the identification uses (ogacq.model), with the hidden truth, seeded noise and
each gauge's arbitrary zero. Gauges are set at the Zero posture (q = 0), as
the papers' protocol sets them.
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from typing import Protocol

import numpy as np

from drivers.sim.clock import SimClock
from drivers.sim.truth import SimTruth
from ogacq.model.machine import MachineSpec
from ogacq.model.measurement import ReadingsLayout, predict_coordinates
from ogacq.model.parameters import AXES, PARAM_INDEX

GAUGE_STROKE_MM = 12.7  # a common indicator stroke: zeros sit near mid-range


class EncoderPositions(Protocol):
    def raw_position_mm(self, axis: str) -> float: ...
    def last_direction(self, axis: str) -> int: ...


class SimMachine:
    def __init__(self, machine: MachineSpec, truth: SimTruth, encoders: EncoderPositions,
                 clock: SimClock, seed: int = 0) -> None:
        self.machine = machine
        self.truth = truth
        self.encoders = encoders
        self.clock = clock
        self._rng = np.random.default_rng(seed)
        self._lock = threading.Lock()
        # Each gauge's reading at its setting posture: somewhere mid-stroke.
        self._zero_mm = {(j, i): float(self._rng.uniform(0.4, 0.6) * GAUGE_STROKE_MM)
                         for i in range(3) for j in range(3) if i != j}
        # A gauge polled at rest asks the same pose again and again: without drift
        # its noise-free coordinate depends on the pose only, so keep it.
        self._drifts = bool(np.any(truth.theta[[PARAM_INDEX[f"thermal_drift.{a}"]
                                                for a in AXES]] != 0))
        self._pose_cache: dict[tuple, float] = {}

    def coordinate_mm(self, gauge_axis: int, leg: int, q_mm: np.ndarray,
                      approach: np.ndarray, t_s: float) -> float:
        """Noise-free coordinate the gauge sees with the joints at ``q_mm``."""
        layout = ReadingsLayout(
            q_mm=self.truth.disturbed_q(q_mm)[None], leg=np.array([leg]),
            gauge_axis=np.array([gauge_axis]), t_s=np.array([t_s]), cycle=np.array([1]),
            tcp_mm=np.full((1, 3), np.nan), approach=np.asarray(approach, int)[None],
            gauge=np.array([0]), gauge_keys=((gauge_axis, leg),),
            setting_q_mm=np.zeros((1, 3)))
        return float(predict_coordinates(self.truth.theta, layout, self.machine)[0])

    def gauge_value_mm(self, gauge_axis: int, leg: int) -> float:
        """What the gauge along ``gauge_axis`` on ``leg`` reads now, noise included."""
        q = tuple(self.encoders.raw_position_mm(a) for a in AXES)
        approach = tuple(self.encoders.last_direction(a) for a in AXES)
        key = (gauge_axis, leg, q, approach)
        coord = None if self._drifts else self._pose_cache.get(key)
        if coord is None:
            coord = self.coordinate_mm(gauge_axis, leg, np.array(q), np.array(approach),
                                       self.clock.now())
            if not self._drifts and len(self._pose_cache) < 10_000:
                self._pose_cache[key] = coord
        with self._lock:
            noise = self._rng.normal(0.0, self.truth.noise_mm) if self.truth.noise_mm else 0.0
        return self._zero_mm[(gauge_axis, leg)] + coord + noise

    def value_source(self, gauge_axis: int, leg: int) -> Callable[[], float]:
        return lambda: self.gauge_value_mm(gauge_axis, leg)
