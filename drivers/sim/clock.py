"""The simulated machine's clock.

Every simulated endpoint (motion model, gauges, thermal drift) reads one clock so
they agree on what "now" is. ``speed`` > 1 runs simulated physics faster than
real time (moves and settling finish sooner) while bytes on the wire keep their
real timing.
"""

from __future__ import annotations

import threading
import time


class SimClock:
    """Simulated seconds since start, advancing ``speed`` times faster than real time."""

    def __init__(self, speed: float = 1.0) -> None:
        if speed <= 0:
            raise ValueError(f"clock speed must be positive, got {speed}")
        self.speed = speed
        self._real_start = time.monotonic()
        self._lock = threading.Lock()
        self._extra_s = 0.0
        self._held_at: float | None = None  # simulated time it stands at while held

    def now(self) -> float:
        """Simulated seconds since the clock started."""
        with self._lock:
            return self._running() if self._held_at is None else self._held_at

    def _running(self) -> float:
        return (time.monotonic() - self._real_start) * self.speed + self._extra_s

    def advance(self, seconds: float) -> None:
        """Jump simulated time forward (tests use it to skip waits without sleeping)."""
        with self._lock:
            self._extra_s += seconds
            if self._held_at is not None:
                self._held_at += seconds

    def hold(self) -> None:
        """Stand still until :meth:`release` (only :meth:`advance` moves it): a test
        then looks at the simulated machine mid-move however slowly a loaded machine
        runs the test, with no race against real time."""
        with self._lock:
            if self._held_at is None:
                self._held_at = self._running()

    def release(self) -> None:
        """Run on from where it was held."""
        with self._lock:
            if self._held_at is not None:
                self._extra_s += self._held_at - self._running()
                self._held_at = None


#: The last stretch before a deadline that is spun rather than slept: the OS
#: wakes a sleeper 0.05-0.15 ms late (timer slack), which a simulated line
#: would add to every frame it delivers.
_SPIN_S = 0.0004


def sleep_until(deadline: float) -> None:
    """Return at ``deadline`` (a ``time.monotonic()`` value), a few µs late at most.

    Sleeps until just before it, then spins. The spin holds the GIL for at most
    ``_SPIN_S``, so it is kept for the moments a client waits on (the end of a
    simulated request or frame); use plain sleeps where lateness cannot be seen."""
    remaining = deadline - time.monotonic()
    if remaining > _SPIN_S:
        time.sleep(remaining - _SPIN_S)
    while time.monotonic() < deadline:
        pass
