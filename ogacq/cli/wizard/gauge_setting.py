"""Setting the gauges at a leg's Zero posture (``SetGauges``): an instruction and a
drawing, live values while the stands are adjusted, then on Enter a check that each
answers, is steady, and has the travel the cycles will ask both ways."""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
from rich.console import Group
from rich.live import Live
from rich.table import Table
from rich.text import Text

from ogacq_drivers.errors import DriverError
from ogacq.cli.plain import shown, table_of
from ogacq.cli.wizard.drawing import leg_drawing, leg_instructions
from ogacq.cli.wizard.guided_station import GuidedStation
from ogacq.cli.wizard.ui import Keys, Option, Screen, detail, parse_mm
from ogacq.model.expected_readings import ReadingExpectations, travel_needed_mm
from ogacq.model.gauges import Gauge, gauges_on
from ogacq.model.machine import MachineSpec
from ogacq.model.measurement import posture_tcp
from ogacq.protocol.plan import ProtocolConfig, Read, SetGauges, StabilityRule

BAR_CELLS = 25
LIVE_PERIOD_S = 0.25


@dataclass
class GaugeCheck:
    gauge: str
    value_mm: float | None
    problem: str = ""  # empty when the gauge is fine
    silent: bool = False


@dataclass
class RunHandles:
    """What the current run gives the wizard's callbacks (they change at each resume)."""

    station: GuidedStation | None = None
    note: Callable[..., None] = lambda action, **fields: None


class LegSetter:
    """The runner's ``set_gauges`` callback."""

    def __init__(self, screen: Screen, config: ProtocolConfig, steps: Sequence[Read],
                 machine: MachineSpec, handles: RunHandles, by_eye: set[str],
                 expectations: ReadingExpectations, gauge_range_mm: float,
                 max_offset_mm: float, pause: Callable[[str], None],
                 shown_value: Callable[[str], float] | None = None) -> None:
        self.screen = screen
        self.config = config
        self.steps = list(steps)
        self.machine = machine
        self.handles = handles
        self.by_eye = by_eye
        self.expectations = expectations
        self.gauge_range_mm = gauge_range_mm
        self.max_offset_mm = max_offset_mm
        self.pause = pause
        self.shown_value = shown_value  # rehearsal: what a simulated dial shows
        self._travel: dict[str, float] = {}
        self._in_place: bool | None = None  # six left in place: set once (first leg)
        self.check_rule = StabilityRule(
            readings=config.stability.readings,
            tolerance_mm=max(config.stability.tolerance_mm, 2 * machine.gauge_resolution_mm),
            timeout_s=min(config.stability.timeout_s, 3.0))

    def travel_mm(self, gauge: str) -> float:
        """Travel a gauge needs on each side of where it is set (with a small margin)."""
        if gauge not in self._travel:
            self._travel[gauge] = travel_needed_mm(self.machine, gauge, self.steps,
                                                   self.max_offset_mm) + 0.1
        return self._travel[gauge]

    # -------------------------------------------------------------------- the step
    def __call__(self, step: SetGauges) -> None:
        if self._in_place is None:  # decided at the first leg, for the whole run
            self._in_place = self._six_in_place()
            if self._in_place:
                self._set_all(step)
                return
        if self._in_place and self._still_set(step):
            return
        self._set_leg(step)

    # -------------------------------------------------------- six indicators left in place
    def _six_in_place(self) -> bool:
        """Whether the six are set once, at the first leg: each on its own link, and the
        first posture Zero, the machine's centre for every leg."""
        gauges = [g for step in self._settings() for g in step.gauges]
        if len(self.config.legs) < 2 or any(not self._station().can_read(g) for g in gauges):
            return False
        described = self._station().description.get("gauges") or {}
        links = [(described.get(g, {}).get("port"), described.get(g, {}).get("channel"))
                 for g in gauges]
        centre = not np.any(posture_tcp(0, self.config.postures[0], self.machine))
        return len(set(links)) == len(links) and centre

    def _settings(self, first: str | None = None) -> list[SetGauges]:
        """The legs' settings, from leg ``first`` on (a resumed campaign's pending one)."""
        legs = list(self.config.legs)
        legs = legs[legs.index(first):] if first in legs else legs
        return [SetGauges(leg, tuple(g.key for g in gauges_on(leg))) for leg in legs]

    def _set_all(self, first: SetGauges) -> None:
        """The gauges of this leg and the next set at once, where the first leg's Zero
        puts the machine."""
        s = self.screen
        settings = self._settings(first.leg)
        every = SetGauges(first.leg, tuple(g for step in settings for g in step.gauges))
        s.heading(f"Set the {len(every.gauges)} gauges", "once, for every leg")
        s.say("The machine is at its Zero posture, the same for every leg. The indicators "
              "stay in place for the whole campaign: set them all now; the wizard will not "
              "stop at the other legs.")
        for step in settings:
            s.say(f"[bold]{step.leg} leg[/]")
            for line in leg_instructions(step.leg):
                s.say(f"  • {shown(line)}")
            s.say(Text(leg_drawing(step.leg, s.out.width)))
        self._set_until_checked(every, "while setting the gauges")

    def _still_set(self, step: SetGauges) -> bool:
        """A later leg, its gauges set at the start: checked without stopping; True when
        they are steady with travel both ways (else the leg is set as usual)."""
        if any(not self._station().can_read(g) for g in step.gauges):
            return False  # switched to reading by eye since: its dial needs a value here
        checks = [self._check(g) for g in step.gauges]
        for failed in (c for c in checks if c.problem):
            self.screen.problem(failed.problem)
        if any(c.problem for c in checks):
            return False
        values = {c.gauge: c.value_mm for c in checks}
        self.screen.ok(f"{step.leg} leg: gauges " + ", ".join(
            f"{c.gauge} {c.value_mm:.4f} mm" for c in checks)
            + ", set at the start: steady, enough travel both ways")
        self.handles.note("gauges_checked", leg=step.leg, values_mm=values)
        return True

    # -------------------------------------------------------------------- leg by leg
    def _set_leg(self, step: SetGauges) -> None:
        legs = self.config.legs
        s = self.screen
        s.heading(f"Leg {step.leg}: set the two gauges",
                  f"leg {legs.index(step.leg) + 1} of {len(legs)}")
        s.say(f"The machine is at the Zero posture of the {step.leg} leg. "
              "Leave it there while you set the gauges.")
        for line in leg_instructions(step.leg) + self._moved_here(step):
            s.say(f"  • {shown(line)}")
        s.say()
        s.say(Text(leg_drawing(step.leg, s.out.width)))
        s.say()
        self._set_until_checked(step, f"while setting the gauges of the {step.leg} leg")

    def _set_until_checked(self, step: SetGauges, where: str) -> None:
        """The travel the cycles ask, then set and checked until done; Ctrl-C pauses."""
        travel = max(self.travel_mm(g) for g in step.gauges)
        self.screen.say(f"During the cycles each reading will move by up to ±{travel:.2f} mm "
                        "from where you set it.")
        while True:
            try:
                if self._set_and_check(step):
                    return
            except KeyboardInterrupt:
                self.pause(where)

    def _moved_here(self, step: SetGauges) -> list[str]:
        """Which indicator each gauge is, when indicators go from leg to leg."""
        gauges = self._station().description.get("gauges") or {}
        links = {key: (g.get("port"), g.get("channel")) for key, g in gauges.items()}
        lines = []
        for gauge in step.gauges:
            if gauge in links and list(links.values()).count(links[gauge]) > 1:
                port, channel = links[gauge]
                where = f"{port}" + (f" channel {channel}" if channel else "")
                lines.append(f"Gauge {gauge} is the indicator on {where}: it goes from leg "
                             "to leg; set it here.")
        return lines

    def _set_and_check(self, step: SetGauges) -> bool:
        """True when the leg's gauges are set (checked, or the check skipped with a reason)."""
        served = [g for g in step.gauges if self._station().can_read(g)]
        checks: list[GaugeCheck] = []
        if served:
            self._live_values(served)
            self.screen.say("Checking …")
            checks = [self._check(g) for g in served]
            for check in checks:
                if check.problem:
                    self.screen.problem(check.problem)
                else:
                    self.screen.ok(f"{check.gauge} reads {check.value_mm:.4f} mm, steady, "
                                   "enough travel both ways")
        for gauge in step.gauges:
            if gauge not in served:
                self._reference_by_eye(step, gauge)
        values = {c.gauge: c.value_mm for c in checks}
        failed = [c for c in checks if c.problem]
        if not failed:
            self.handles.note("gauges_checked", leg=step.leg, values_mm=values)
            return True
        options = [Option("r", "adjust and check again")]
        silent = [c.gauge for c in failed if c.silent]
        eye_keys = {("m" if len(silent) == 1 else f"m{k}"): gauge
                    for k, gauge in enumerate(silent, 1)}
        for key, gauge in eye_keys.items():
            options.append(Option(key, f"read {gauge} by eye from now on (type its values)"))
        options.append(Option("s", "go on as they are (give a reason)"))
        choice = self.screen.choose("What now?", options, default="r")
        if choice in eye_keys:
            gauge = eye_keys[choice]
            reason = self.screen.reason(f"read {gauge} by eye")
            self.by_eye.add(gauge)
            self.handles.note("read_by_eye", gauge=gauge, leg=step.leg, reason=reason)
            if len(failed) > 1:
                return False  # the others still need adjusting: check again
            self._reference_by_eye(step, gauge)
            self.handles.note("gauges_checked", leg=step.leg,
                              values_mm={g: v for g, v in values.items() if g != gauge})
            return True
        if choice == "s":
            reason = self.screen.reason("go on with these gauges")
            self.handles.note("skip", step="gauge check", leg=step.leg, values_mm=values,
                              problems=[c.problem for c in failed], reason=reason)
            return True
        return False

    # -------------------------------------------------------------------- live values
    def _live_values(self, gauges: Sequence[str]) -> None:
        """Values updating in place until Enter."""
        station = self._station()
        with Keys() as reader:
            if not reader.interactive:
                self.screen.say(self._table(gauges, {g: self._read(station, g)
                                                     for g in gauges}))
                self.screen.ask("Press Enter when the gauges are set", "")
                return
            latest = {g: self._read(station, g) for g in gauges}
            live = Live(self._live_view(gauges, latest), console=self.screen.out,
                        auto_refresh=False, transient=False)
            self.screen.show_live(live)
            try:
                while True:
                    key = reader.poll(LIVE_PERIOD_S)
                    if key is not None and ("\n" in key or "\r" in key):
                        return
                    latest = {g: self._read(station, g) for g in gauges}
                    live.update(self._live_view(gauges, latest), refresh=True)
            finally:
                self.screen.stop_live()

    @staticmethod
    def _read(station: GuidedStation, gauge: str) -> tuple[float | None, str]:
        try:
            return station.read_once(gauge), ""
        except DriverError as exc:
            return None, detail(exc)

    def _live_view(self, gauges: Sequence[str], latest: dict) -> Group:
        hint = Text.from_markup(f"[dim]live {time.strftime('%H:%M:%S')}[/]   [bold]Enter[/]: "
                                "the gauges are set, check them   [bold]Ctrl-C[/]: pause")
        return Group(self._table(gauges, latest), hint)

    def _table(self, gauges: Sequence[str], latest: dict) -> Table:
        table = table_of("gauge", ">reads", f"plunger travel 0 … {self.gauge_range_mm:g} mm", "")
        for gauge in gauges:
            value, error = latest[gauge]
            if value is None:
                table.add_row(gauge, "[red]---[/]", "", f"[red]{shown(error)}[/]")
                continue
            need = self.travel_mm(gauge)
            fine = need <= value <= self.gauge_range_mm - need
            state = "[green]mid-range[/]" if fine else f"[yellow]{self._advice(value, need)}[/]"
            table.add_row(gauge, f"{value:.4f} mm", self._bar(value, need), state)
        return table

    def _bar(self, value: float, need: float) -> Text:
        span = self.gauge_range_mm
        cells = ["-" if need <= (k + 0.5) * span / BAR_CELLS <= span - need else "."
                 for k in range(BAR_CELLS)]
        marker = min(BAR_CELLS - 1, max(0, int(value / span * BAR_CELLS)))
        bar = Text("[")
        bar.append("".join(cells[:marker]), style="dim")
        bar.append("O", style="bold")
        bar.append("".join(cells[marker + 1:]), style="dim")
        bar.append("]")
        return bar

    def _advice(self, value: float, need: float) -> str:
        middle = self.gauge_range_mm / 2
        if value < need:
            return f"plunger almost out: push the gauge in by about {middle - value:.1f} mm"
        return f"plunger almost fully in: pull the gauge back by about {value - middle:.1f} mm"

    # -------------------------------------------------------------------- the check
    def _check(self, gauge: str) -> GaugeCheck:
        station = self._station()
        port = station.description.get("gauges", {}).get(gauge, {}).get("port", "its port")
        try:
            value = station.read_steady(gauge, self.check_rule)
        except DriverError as exc:
            if "settle" in str(exc):
                return GaugeCheck(gauge, None, f"{gauge} is not steady: {detail(exc)}. Is its "
                                  "stand tight, and is the leg still?")
            return GaugeCheck(gauge, None, f"gauge {gauge} does not answer on {port}: "
                              f"{detail(exc)}. Check its cable, that it is switched on, and "
                              "its battery.", silent=True)
        need = self.travel_mm(gauge)
        if not need <= value <= self.gauge_range_mm - need:
            return GaugeCheck(gauge, value, f"{gauge} reads {value:.4f} mm: "
                              f"{self._advice(value, need)} (it needs {need:.2f} mm of travel "
                              "each way)")
        return GaugeCheck(gauge, value)

    def _reference_by_eye(self, step: SetGauges, gauge: str) -> None:
        """A dial's value as set: the reference its readings are checked against (at
        its own leg's first posture: where it was set)."""
        leg = Gauge.parse(gauge).leg
        first = next(s for s in self.steps if s.leg == leg)
        span = self.gauge_range_mm

        def parse(text: str) -> float:
            value = parse_mm(text)
            if abs(value) > span:
                raise ValueError(f"{value:g} mm is beyond the dial's {span:g} mm range")
            return value

        if self.shown_value is not None:
            self.screen.note(f"(rehearsal: the simulated gauge {gauge} shows "
                             f"{self.shown_value(gauge):.3f})")
        value = self.screen.ask_parsed(f"{gauge}, read by eye: what does it show now (mm)?",
                                       parse)
        self.expectations.set_reference(gauge, first.q_mm, value)
        self.handles.note("dial_set", gauge=gauge, leg=leg, value_mm=value)

    def _station(self) -> GuidedStation:
        assert self.handles.station is not None, "set_gauges is only called during a run"
        return self.handles.station
