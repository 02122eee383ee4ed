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

from ogacq_drivers.sim.clock import SimClock
from ogacq.model.error_maps import JointHistory
from ogacq.model.gauges import GAUGE_INDICES
from ogacq.model.machine import MachineSpec
from ogacq.model.measurement import ReadingsLayout
from ogacq.model.parameters import AXES, PARAM_INDEX
from ogacq.sim.physics import joint_travel_mm, true_coordinates
from ogacq.sim.truth import SimTruth

GAUGE_STROKE_MM = 12.7  # a common indicator stroke: zeros sit near mid-range


class EncoderPositions(Protocol):
    def raw_position_mm(self, axis: str) -> float: ...
    def last_direction(self, axis: str) -> int: ...
    def stopped_at_s(self) -> float | None: ...


def _travel_since_reversal(encoders: EncoderPositions, axis: str) -> float:
    """How far the axis has moved since it last reversed (a hysteresis builds up over
    it); inf when the encoders do not follow it or it never reversed."""
    travel = getattr(encoders, "travel_since_reversal_mm", None)
    return float("inf") if travel is None else float(travel(axis))


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
        self._zero_mm = {key: float(self._rng.uniform(0.4, 0.6) * GAUGE_STROKE_MM)
                         for key in GAUGE_INDICES}
        # A gauge polled at rest asks the same pose again and again: without drift
        # its noise-free coordinate depends on the pose only, so keep it.
        self._drifts = bool(np.any(truth.theta[[PARAM_INDEX[f"thermal_drift.{a}"]
                                                for a in AXES]] != 0)) or bool(truth.warm_up)
        self._pose_cache: dict[tuple, dict[tuple[int, int], float]] = {}
        # Each stop's ringing, per gauge: (amplitude, phase), drawn from the seed and
        # the stop's number, so the same campaign rings the same way (the noise's own
        # generator is left to the noise).
        self._seed = seed
        self._ringing: tuple[float, dict[tuple[int, int], tuple[float, float]]] | None = None
        self._stops = 0
        self._shown_at: dict[object, float] = {}  # when each reader last showed a value

    def coordinates_mm(self, q_mm: np.ndarray, approach: np.ndarray, t_s: float,
                       travel_mm: np.ndarray | None = None) -> dict[tuple[int, int], float]:
        """Noise-free coordinate every gauge (gauge_axis, leg) sees with the joints at
        ``q_mm``: all six in one evaluation, since the gauges are read pose by pose.
        ``travel_mm``: each joint's travel since its last reversal (None: long). The
        gauges are set at Zero, whose joints' side the simulator does not follow: a
        hysteresis is left out there (its effect on where a gauge sits is a part in a
        thousand of it)."""
        n = len(GAUGE_INDICES)
        side = np.repeat(np.asarray(approach, int)[None], n, axis=0)
        travel = np.full((n, 3), np.inf) if travel_mm is None else \
            np.repeat(np.asarray(travel_mm, float)[None], n, axis=0)
        layout = ReadingsLayout(
            q_mm=np.repeat(np.asarray(q_mm, float)[None], n, axis=0),
            leg=np.array([leg for _, leg in GAUGE_INDICES]),
            gauge_axis=np.array([axis for axis, _ in GAUGE_INDICES]),
            t_s=np.full(n, t_s), cycle=np.ones(n, dtype=int),
            tcp_mm=np.full((n, 3), np.nan), approach=side,
            gauge=np.arange(n), gauge_keys=GAUGE_INDICES, setting_q_mm=np.zeros((n, 3)))
        history = JointHistory(layout.q_mm, side, travel, layout.t_s, layout.setting_q_mm,
                               np.zeros((n, 3), dtype=int), np.full((n, 3), np.inf))
        values = true_coordinates(self.truth, layout, self.machine, history)
        return {key: float(v) for key, v in zip(GAUGE_INDICES, values, strict=True)}

    def gauge_value_mm(self, gauge_axis: int, leg: int) -> float:
        """What the gauge along ``gauge_axis`` on ``leg`` reads now, noise included."""
        q = tuple(self.encoders.raw_position_mm(a) for a in AXES)
        approach = tuple(self.encoders.last_direction(a) for a in AXES)
        travel = tuple(_travel_since_reversal(self.encoders, a) for a in AXES) \
            if self.truth.hysteresis else None
        pose = (q, approach, travel)
        coords = None if self._drifts else self._pose_cache.get(pose)
        if coords is None:
            coords = self.coordinates_mm(np.array(q), np.array(approach), self.clock.now(),
                                         None if travel is None else np.array(travel))
            if not self._drifts and len(self._pose_cache) < 2_000:
                self._pose_cache[pose] = coords
        with self._lock:
            noise = self._rng.normal(0.0, self.truth.noise_mm) if self.truth.noise_mm else 0.0
        return (self._zero_mm[(gauge_axis, leg)] + coords[(gauge_axis, leg)] + noise
                + self.vibration_mm(gauge_axis, leg))

    def rest_value_mm(self, gauge_axis: int, leg: int) -> float:
        """What the gauge would read now were the machine still and the gauge without
        noise or display step: the truth a reading is judged against (benches, tests)."""
        q = np.array([self.encoders.raw_position_mm(a) for a in AXES])
        approach = np.array([self.encoders.last_direction(a) for a in AXES])
        travel = np.array([_travel_since_reversal(self.encoders, a) for a in AXES])
        coords = self.coordinates_mm(q, approach, self.clock.now(), travel)
        return self._zero_mm[(gauge_axis, leg)] + coords[(gauge_axis, leg)]

    def vibration_mm(self, gauge_axis: int, leg: int, reader: object = None) -> float:
        """The machine's ringing the gauge shows now (0 while an axis moves; the
        motion itself is in the coordinates): its mean since ``reader`` (the gauge by
        default) last showed a value, or since the stop, as a display that integrates
        between its updates shows it. No source: the simulator's choice. A rehearsal
        at speed asks its gauges as fast as Python turns the exchanges round, not at
        the line's rate (a value every 50 ms of machine time at 100x): sampled at a
        point, a 20 Hz ringing aliased there and passed for rest, and slowed to what
        the line could sample it crept slower than any settle window (0.8 Hz at 25x, a
        micrometre left in every reading). Read as often as a real line allows (an
        01A exchange every 15.6 ms) the mean keeps 85 % of a 20 Hz ringing."""
        vibration = self.truth.vibration
        if vibration.amplitude_mm == 0:
            return 0.0
        stopped = self.encoders.stopped_at_s()
        if stopped is None:
            return 0.0
        now = self.clock.now()
        key = (gauge_axis, leg) if reader is None else reader
        with self._lock:
            if self._ringing is None or self._ringing[0] != stopped:
                self._stops += 1
                rng = np.random.default_rng([self._seed, 20, self._stops])
                self._ringing = (stopped, {key: (float(rng.uniform(0.5, 1.0)),
                                                 float(rng.uniform(0.0, 2 * np.pi)))
                                           for key in GAUGE_INDICES})
            share, phase = self._ringing[1][(gauge_axis, leg)]
            last = self._shown_at.get(key)
            self._shown_at[key] = now
        since = now - stopped
        start = since if last is None else min(max(last - stopped, 0.0), since)
        return vibration.mean_mm(share, phase, start, since)

    def value_source(self, gauge_axis: int, leg: int) -> Callable[[], float]:
        return lambda: self.gauge_value_mm(gauge_axis, leg)

    def joint_mm(self, axis: int) -> float:
        """Where joint ``axis`` actually is now along its line, from its zero (noise-free):
        what a scale along its actuator reads up to the scale's own zero."""
        q = np.array([self.encoders.raw_position_mm(b) for b in AXES])
        side = np.array([self.encoders.last_direction(b) for b in AXES])
        travel = np.array([_travel_since_reversal(self.encoders, b) for b in AXES])
        return joint_travel_mm(self.truth, axis, q, side, travel, self.clock.now())

    def scale_source(self, axis: int, noise_mm: float) -> Callable[[], float]:
        """What a scale along actuator ``axis`` reads: the joint's place counted from its
        nominal zero (rho = L; a scale's counter is zeroed wherever it is mounted, and a
        test reads it up to that constant), its own noise (seeded apart from the gauges')
        and the carriage's ringing along it."""
        rng = np.random.default_rng([self._seed, 30, axis])
        lock = threading.Lock()

        def read() -> float:
            with lock:
                noise = float(rng.normal(0.0, noise_mm)) if noise_mm else 0.0
            return self.joint_mm(axis) + noise + self.vibration_mm(axis, (axis + 1) % 3,
                                                                   ("scale", axis))

        return read
