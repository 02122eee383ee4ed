"""Several indicators read at once, and a settle that ends when their values agree.

The gauges of one posture are independent instruments on their own lines: reading
them one after the other adds their line times, reading them at once costs the
slowest. Gauges that share a line (a multiplexer's channels, one indicator moved
from leg to leg) are read in turn by one worker, since a line carries one exchange
at a time; each line gets its own worker. Every gauge's outcome comes back,
value or error, so one failing gauge never loses the others' readings.

:func:`settle_many` reads from the moment the axes are in position and stops each
gauge once its values show the machine at rest (:mod:`ogacq_drivers.indicators.rest`):
the settle lasts as long as the machine rings, not a fixed time (``bound_s`` caps
it). Each gauge's rest reference is measured at its first settle and kept by the
reader for the run.
"""

from __future__ import annotations

import threading
from collections.abc import Callable, Mapping, Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from typing import Any, TypeVar

from ogacq_drivers.errors import DeviceBusy, DriverError, FrameError
from ogacq_drivers.indicators.base import Indicator, StableReading, read_stable
from ogacq_drivers.indicators.rest import RestJudge, RestReference
from ogacq_drivers.threads import leave_interrupts_to_the_main_thread

T = TypeVar("T")
Clock = Callable[[], float]


@dataclass(frozen=True, slots=True)
class Settled:
    """A gauge's settle: ``reading`` (the mean of its two windows at rest) once it was at
    rest, None when ``bound_s`` passed first. ``reference``: the rest reference it was
    judged against, ``measured`` when this settle measured it (waiting the bound)."""

    reading: StableReading | None
    waited_s: float  # clock seconds from the start of the settle to its last value
    values: int  # values read during the settle
    reference: RestReference | None = None
    measured: bool = False
    # judged against a reference and not at rest by the bound: its last two windows'
    # mean all the same (RestJudge.last_values), for a caller that reads on no longer
    unjudged: StableReading | None = None


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
        # what each gauge showed at rest, measured at its first settle of the run
        self.rest: dict[str, RestReference] = {}

    def close(self) -> None:
        self._stop.set()
        if self._pool is not None:
            self._pool.shutdown(wait=True)
            self._pool = None

    def read_stable_many(self, gauges: Sequence[str], n: int, tolerance_mm: float,
                         timeout_s: float) -> dict[str, StableReading | DriverError]:
        """A stable reading of each gauge (:func:`read_stable`), or the error it raised."""
        def line(group: list[str]) -> dict[str, StableReading | DriverError]:
            out: dict[str, StableReading | DriverError] = {}
            for gauge in group:
                try:
                    out[gauge] = read_stable(self.indicators[gauge], n, tolerance_mm, timeout_s)
                except DriverError as exc:
                    out[gauge] = exc
            return out

        return self._gathered(gauges, line)

    def settle_many(self, gauges: Sequence[str], *, window_s: float, bound_s: float,
                    display_step_mm: float, clock: Clock) -> dict[str, Settled | DriverError]:
        """Read each gauge until its values show rest (:class:`RestJudge`: two windows of
        ``window_s`` consistent with its rest reference), or until ``bound_s`` of
        ``clock`` has passed since the call. A gauge without a rest reference yet
        reads to the bound and measures it over the bound's second half."""
        start = clock()

        def line(group: list[str]) -> dict[str, Settled | DriverError]:
            judges = {g: RestJudge(window_s, display_step_mm, self.rest.get(g)) for g in group}
            return _settle_line(self.indicators, judges, bound_s=bound_s, clock=clock,
                                start=start, stop=self._stop)

        out = self._gathered(gauges, line)
        for gauge, settled in out.items():
            if isinstance(settled, Settled) and settled.measured and settled.reference:
                self.rest[gauge] = settled.reference
        return out

    # ------------------------------------------------------------------ internals
    def _gathered(self, gauges: Sequence[str], line: Callable[[list[str]], dict[str, T]],
                  ) -> dict[str, T]:
        """``line`` of each line's gauges (the lines read in parallel), in ``gauges``' order."""
        out: dict[str, T] = {}
        for result in self._map(line, line_groups({g: self.indicators[g] for g in gauges})):
            out.update(result)
        return {g: out[g] for g in gauges}

    def _map(self, work: Callable[[list[str]], T], groups: list[list[str]]) -> list[T]:
        if len(groups) == 1:  # one line: no hand-over to a worker
            return [work(groups[0])]
        if self._pool is None:
            self._pool = ThreadPoolExecutor(max_workers=6, thread_name_prefix="gauge-line",
                                            initializer=leave_interrupts_to_the_main_thread)
        # The caller reads the first line itself while the workers read the others.
        futures = [self._pool.submit(work, group) for group in groups[1:]]
        try:
            first = work(groups[0])
        except BaseException:
            for future in futures:
                future.cancel()
            raise
        return [first, *(future.result() for future in futures)]


def _settle_line(indicators: Mapping[str, Indicator], judges: dict[str, RestJudge], *,
                 bound_s: float, clock: Clock, start: float, stop: threading.Event,
                 ) -> dict[str, Any]:
    """The gauges of one line, read in turn until each is at rest (or the bound)."""
    out: dict[str, Settled | DriverError] = {}
    for gauge in judges:
        indicators[gauge].flush_input()  # what arrived before the move ended is not rest
    while len(out) < len(judges) and not stop.is_set():
        for gauge, judge in judges.items():
            if gauge in out:
                continue
            try:
                reading = indicators[gauge].read()
            except (FrameError, DeviceBusy):  # breaks the run of values, as read_stable's
                judge.clear()
                rest = None
            except DriverError as exc:
                out[gauge] = exc
                continue
            else:
                rest = judge.add(clock() - start, reading)
            now = clock() - start
            if rest is not None:
                out[gauge] = Settled(rest, now, judge.count, judge.reference)
            elif now >= bound_s:
                if judge.reference is None:  # the machine as still as after a fixed wait
                    measured = judge.rest_from_tail(bound_s / 2)
                    out[gauge] = Settled(None, now, judge.count, measured, measured is not None)
                else:
                    out[gauge] = Settled(None, now, judge.count, judge.reference,
                                         unjudged=judge.last_values())
    return out
