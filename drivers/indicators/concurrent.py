"""Several indicators read at once, and a settle that ends when their values agree.

The gauges of one posture are independent instruments on their own lines: reading
them one after the other adds their line times, reading them at once costs the
slowest. Gauges that share a line (a multiplexer's channels, one indicator moved
from leg to leg) are read in turn by one worker, since a line carries one exchange
at a time; each line gets its own worker. Every gauge's outcome comes back,
value or error, so one failing gauge never loses the others' readings.

:func:`settle_many` reads from the moment the axes are in position and stops each
gauge once its values of the last ``window_s`` agree: the settle lasts as long as
the machine rings, not a fixed time (``bound_s`` caps it).
"""

from __future__ import annotations

import threading
from collections import deque
from collections.abc import Callable, Mapping, Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from typing import Any, TypeVar

from ogacq_drivers.errors import DeviceBusy, DriverError, FrameError
from ogacq_drivers.indicators.base import Indicator, Reading, StableReading, read_stable

T = TypeVar("T")
Clock = Callable[[], float]


@dataclass(frozen=True, slots=True)
class Settled:
    """A gauge's settle: ``reading`` (the mean of its last ``n`` agreeing values) once
    its values agreed, None when ``bound_s`` passed first."""

    reading: StableReading | None
    waited_s: float  # clock seconds from the start of the settle to its last value
    values: int  # values read during the settle


def line_groups(indicators: Mapping[str, Indicator]) -> list[list[str]]:
    """The gauges grouped by the line they are read through, in the given order: a
    serial driver's link, else the driver itself (a USB cable, an input device)."""
    groups: dict[int, list[str]] = {}
    for gauge, indicator in indicators.items():
        groups.setdefault(id(getattr(indicator, "link", indicator)), []).append(gauge)
    return list(groups.values())


class ConcurrentReader:
    """Reads gauges line by line in parallel; one worker per line, kept between calls
    (a thread per posture would cost more than the exchange it saves)."""

    def __init__(self, indicators: Mapping[str, Indicator]) -> None:
        self.indicators = indicators
        self._pool: ThreadPoolExecutor | None = None
        self._stop = threading.Event()

    def close(self) -> None:
        self._stop.set()
        if self._pool is not None:
            self._pool.shutdown(wait=True)
            self._pool = None

    def read_stable_many(self, gauges: Sequence[str], n: int, tolerance_mm: float,
                         timeout_s: float) -> dict[str, StableReading | DriverError]:
        """A stable reading of each gauge (:func:`read_stable`), or the error it raised."""
        def one(gauge: str) -> StableReading:
            return read_stable(self.indicators[gauge], n, tolerance_mm, timeout_s)

        return self._per_line(gauges, one)

    def settle_many(self, gauges: Sequence[str], *, window_s: float, n: int,
                    tolerance_mm: float, bound_s: float, clock: Clock,
                    ) -> dict[str, Settled | DriverError]:
        """Read each gauge until its values of the last ``window_s`` (at least ``n``,
        spanning at least ``window_s`` of ``clock``) agree within ``tolerance_mm``,
        or until ``bound_s`` of ``clock`` has passed since the call."""
        start = clock()
        by_line = line_groups({g: self.indicators[g] for g in gauges})

        def line(group: list[str]) -> dict[str, Settled | DriverError]:
            return _settle_line(self.indicators, group, window_s=window_s, n=n,
                                tolerance_mm=tolerance_mm, until=start + bound_s,
                                clock=clock, start=start, stop=self._stop)

        out: dict[str, Settled | DriverError] = {}
        for result in self._map(line, by_line):
            out.update(result)
        return {g: out[g] for g in gauges}

    # ------------------------------------------------------------------ internals
    def _per_line(self, gauges: Sequence[str], one: Callable[[str], T],
                  ) -> dict[str, T | DriverError]:
        def line(group: list[str]) -> dict[str, T | DriverError]:
            out: dict[str, T | DriverError] = {}
            for gauge in group:
                try:
                    out[gauge] = one(gauge)
                except DriverError as exc:
                    out[gauge] = exc
            return out

        out: dict[str, T | DriverError] = {}
        for result in self._map(line, line_groups({g: self.indicators[g] for g in gauges})):
            out.update(result)
        return {g: out[g] for g in gauges}

    def _map(self, work: Callable[[list[str]], T], groups: list[list[str]]) -> list[T]:
        if len(groups) == 1:  # one line: no hand-over to a worker
            return [work(groups[0])]
        if self._pool is None:
            self._pool = ThreadPoolExecutor(max_workers=6, thread_name_prefix="gauge-line")
        # The caller reads the first line itself while the workers read the others.
        futures = [self._pool.submit(work, group) for group in groups[1:]]
        try:
            first = work(groups[0])
        except BaseException:
            for future in futures:
                future.cancel()
            raise
        return [first, *(future.result() for future in futures)]


def _settle_line(indicators: Mapping[str, Indicator], group: list[str], *, window_s: float,
                 n: int, tolerance_mm: float, until: float, clock: Clock, start: float,
                 stop: threading.Event) -> dict[str, Any]:
    """The gauges of one line, read in turn until each has settled (or the bound)."""
    windows = {g: _Window(window_s, n, tolerance_mm) for g in group}
    out: dict[str, Settled | DriverError] = {}
    for gauge in group:
        indicators[gauge].flush_input()  # what arrived before the move ended is not rest
    while len(out) < len(group) and not stop.is_set():
        for gauge in group:
            if gauge in out:
                continue
            window = windows[gauge]
            try:
                reading = indicators[gauge].read()
            except (FrameError, DeviceBusy):  # breaks the run of values, as read_stable's
                window.clear()
                stable = None
            except DriverError as exc:
                out[gauge] = exc
                continue
            else:
                stable = window.add(clock(), reading)
            now = clock()
            if stable is not None:
                out[gauge] = Settled(stable, now - start, window.count)
            elif now >= until:
                out[gauge] = Settled(None, now - start, window.count)
    return out


class _Window:
    """A gauge's recent values: at least ``n`` and back to ``window_s`` before the last.

    Settled when the window's peak-to-peak is within twice the tolerance (a ringing's
    amplitude, half its peak-to-peak, within the tolerance) and its last ``n`` values
    agree within the tolerance (a stable reading). The looser bound over the window
    keeps the gauges' own scatter from holding the settle: a window of seven values of
    scatter sigma spans about 2.7 sigma (the expected range of normal samples), three
    values about 1.7 sigma."""

    def __init__(self, window_s: float, n: int, tolerance_mm: float) -> None:
        self.window_s, self.n, self.tolerance_mm = window_s, n, tolerance_mm
        self.values: deque[tuple[float, Reading]] = deque()
        self.count = 0

    def clear(self) -> None:
        self.values.clear()

    def add(self, t: float, reading: Reading) -> StableReading | None:
        """The stable reading once the window's values agree, else None."""
        self.count += 1
        values = self.values
        values.append((t, reading))
        # keep one value at or before the window's start, so its span can be judged
        while len(values) > self.n and values[1][0] <= t - self.window_s:
            values.popleft()
        if len(values) < self.n or values[0][0] > t - self.window_s:
            return None
        # The epsilon keeps quantised values from failing on float noise (as read_stable).
        tolerance = self.tolerance_mm + 1e-9
        mm = [r.value_mm for _, r in values]
        if max(mm) - min(mm) > 2 * tolerance:
            return None
        last = [r for _, r in list(values)[-self.n:]]
        lasts = [r.value_mm for r in last]
        if max(lasts) - min(lasts) > tolerance:
            return None
        return StableReading(value_mm=sum(lasts) / self.n, spread_mm=max(lasts) - min(lasts),
                             readings=tuple(last))
