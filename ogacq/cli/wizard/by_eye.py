"""Dial indicators read by eye (the papers' own 10 um gauges were): a value outside
the expected range is refused once; typed again it is kept (a person who re-read
the dial may be right, and the fit will judge)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from ogacq.cli.wizard.ui import Screen, parse_mm
from ogacq.model.expected_readings import ReadingExpectations
from ogacq.model.gauges import Gauge
from ogacq.protocol.plan import Read
from ogacq.protocol.station import GaugeValue


@dataclass
class ReadingCounter:
    """Readings recorded so far and in all, for "reading 5 of 24" (the observer updates it)."""

    done: int
    total: int


class ByEyeReadings:
    def __init__(self, screen: Screen, expectations: ReadingExpectations, cycles: int,
                 counter: ReadingCounter, resolution_mm: float,
                 on_pause: Callable[[], None],
                 shown_value: Callable[[str], float] | None = None) -> None:
        self.screen = screen
        self.expectations = expectations
        self.cycles = cycles
        self.counter = counter
        self.decimals = max(2, min(4, len(f"{resolution_mm:f}".rstrip("0").split(".")[1])))
        self.on_pause = on_pause
        # Rehearsal only: what the simulated dial shows, so the reading can be typed.
        self.shown_value = shown_value

    def __call__(self, gauge: str, step: Read) -> GaugeValue:
        expected = self.expectations.expected(gauge, step.q_mm)
        where = Gauge.parse(gauge)
        self.screen.stop_live()
        self.screen.say(
            f"[bold]Reading {self.counter.done + 1} of {self.counter.total}[/]  "
            f"{where.leg} leg · cycle {step.cycle} of {self.cycles} · "
            f"{step.posture.title()} posture")
        self.screen.say(f"  Read {gauge} (along {where.axis}) by eye. Expected "
                        f"{expected.describe(self.decimals)}.")
        if self.shown_value is not None:
            self.screen.note(f"  (rehearsal: the simulated gauge shows "
                             f"{self.shown_value(gauge):.{self.decimals}f})")
        refused: float | None = None
        while True:
            try:
                value = self.screen.ask_parsed(f"  {gauge} reads (mm)", parse_mm)
            except KeyboardInterrupt:
                self.on_pause()  # returns to resume; raises to quit
                continue
            if expected.contains(value):
                kept = ""
                break
            if refused is not None and abs(value - refused) < 1e-12:
                kept = " (kept outside the expected range after re-reading)"
                self.screen.note(f"  Kept {value:.{self.decimals}f} mm as typed twice.")
                break
            refused = value
            self.screen.problem(
                f"{value:.{self.decimals}f} mm is outside the expected "
                f"{expected.describe(self.decimals)}.")
            self.screen.say("  Read it again and type it; the same value typed twice is kept.")
            self.screen.say("  (On a dial, count the turns of the small pointer.)")
        return GaugeValue(value, f"typed {value:.{self.decimals}f}{kept}",
                          f"dial {gauge}, read by eye")
