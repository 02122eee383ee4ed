"""The wizard's traceability questions: machine, operator, gauges (offered from the
inventory), temperature; a gauge past its due date refused unless a reason is given.
Enter leaves an answer unrecorded: the budget and the record say so, not a guess."""

from __future__ import annotations

import datetime
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from typing import Any, TypeVar

from ogacq.campaign.inventory import Inventory, KnownGauge
from ogacq.campaign.traceability import expired_instruments
from ogacq.cli.plain import shown
from ogacq.cli.wizard.pause import OperatorQuit
from ogacq.cli.wizard.ui import Option, Screen, typed_number
from ogacq.io.dates import DateError, parse_date
from ogacq.io.names import parsed_name
from ogacq.model.instrument import MAX_CERTIFICATE_U_MM, Instrument
from ogacq.model.machine import MachineSpec

# The shop-floor range a temperature is accepted in (as the campaign file's)
LOWEST_C, HIGHEST_C = -40.0, 80.0

T = TypeVar("T")


@dataclass(frozen=True)
class Indicator:
    """One physical gauge to identify: the plan's gauges it serves (an indicator moved
    from leg to leg serves three) and the serial its link reports, if any."""

    label: str  # "gauge y_x (on /dev/ttyUSB0)"
    gauges: tuple[str, ...]
    serial: str = ""


@dataclass
class Traceability:
    machine: MachineSpec
    operator: str = ""
    ambient_start_c: float | None = None
    identities: dict[str, dict[str, Any]] = field(default_factory=dict)  # gauge key -> keys
    override_expired: str = ""

    def instruments(self, resolution_mm: float | None = None) -> list[Instrument]:
        # an identity holds only the keys known (KnownGauge.identity): Instrument's own
        return [Instrument(gauge, resolution_mm=resolution_mm, **given)
                for gauge, given in self.identities.items()]


def temperature(text: str) -> float | None:
    """A typed temperature in degC (a decimal comma is fine); empty: not measured."""
    text = text.strip().removesuffix("°C").removesuffix("C").strip()
    if not text:
        return None
    value = typed_number(text, "a temperature in °C (for example 20.5)")
    if not LOWEST_C <= value <= HIGHEST_C:
        raise ValueError(f"a temperature in °C between {LOWEST_C:g} and {HIGHEST_C:g}, got "
                         f"{text}")
    return value


def _date(key: str) -> Callable[[str], datetime.date | None]:
    """The parser of a typed date (empty: not known) as ``ask_parsed`` takes it."""
    def parse(text: str) -> datetime.date | None:
        if not text.strip():
            return None
        try:
            return parse_date(text, source=None, key=key)
        except DateError as exc:
            raise ValueError(exc.problem) from None
    return parse


def _positive(text: str) -> float | None:
    """The certificate's U in mm (the unit may follow); empty: not known."""
    text = text.strip().removesuffix("mm").strip()
    if not text:
        return None
    value = typed_number(text, "the certificate's U in mm (for example 0.0015 for "
                               "1.5 µm)")
    if not value > 0:
        raise ValueError(f"a positive number (mm), got {text}")
    if value > MAX_CERTIFICATE_U_MM:
        raise ValueError(f"{value:g} mm is more than an indicator's certificate states (at "
                         f"most {MAX_CERTIFICATE_U_MM:g} mm): micrometres written as mm? type "
                         "it in mm (for example 0.0015 for 1.5 µm)")
    return value


def _coverage(text: str) -> float | None:
    text = text.strip()
    if not text:
        return None
    value = typed_number(text, "the certificate's coverage factor k (usually 2)")
    if not 1 <= value <= 10:
        raise ValueError(f"a coverage factor between 1 and 10 (usually 2), got {text}")
    return value


class TraceabilityQuestions:
    """Asks, in order: the machine's name and serial (when its file has no serial),
    the operator, the ambient temperature, each gauge's identity."""

    def __init__(self, screen: Screen, inventory: Inventory, *,
                 known: Sequence[KnownGauge] = (), ambient_hint_c: float | None = None,
                 ) -> None:
        self.screen = screen
        self.inventory = inventory
        # gauges known without the inventory (a rehearsal's simulated ones)
        self.known = {g.serial: g for g in known}
        self.ambient_hint_c = ambient_hint_c
        # what was answered, by question: Ctrl-C then "resume" asks again from the
        # first question, and each answer given before the pause is offered again
        self._answered: dict[str, str] = {}

    def _ask(self, key: str | None, question: str, parse: Callable[[str], T],
             default: str | None = None, unset: str = "") -> T:
        """``question`` until ``parse`` takes the answer; the answer given to ``key``
        before a pause offered instead of ``default``. ``unset``: what Enter does when
        nothing is offered ("not recorded")."""
        offered = (self._answered.get(key, default) if key else default) or None
        text = f"{question} (Enter: {unset})" if unset and offered is None else question

        def kept(answer: str) -> T:
            value = parse(answer)
            if key:
                self._answered[key] = answer
            return value

        return self.screen.ask_parsed(text, kept, offered)

    def ask(self, machine: MachineSpec, indicators: Sequence[Indicator],
            on: datetime.date) -> Traceability:
        s = self.screen
        s.say("Who, what and when: recorded in the session and the report (Enter leaves a "
              "value unrecorded).")
        if self._answered:
            s.note("The answers given before the pause are offered again: Enter keeps each.")
        if not machine.serial:
            name = self._ask("machine", "Machine name", str, default=machine.name or None)
            serial = self._ask("serial", "Machine serial number", str, unset="not recorded")
            machine = replace(machine, name=name or machine.name, serial=serial)
        operator = self._ask("operator", "Operator (your name)", parsed_name,
                             default=self.inventory.operator or None)
        if operator:
            self.inventory.operator = operator
        ambient = self.ask_temperature("Ambient temperature now, °C", key="ambient")
        trace = Traceability(machine, operator, ambient)
        if self.inventory.gauges:
            s.note("Gauges met before: " + "; ".join(
                f"{g.serial} ({g.summary()})" for g in self.inventory.gauges.values()))
        for indicator in indicators:
            identity = self._identify(indicator)
            for gauge in indicator.gauges:
                trace.identities[gauge] = identity
        self.inventory.save()
        trace.override_expired = self._check_due(trace, indicators, on)
        return trace

    def ask_temperature(self, question: str, key: str | None = None) -> float | None:
        """A temperature now (``key``: as :meth:`_ask`)."""
        hint = f"{self.ambient_hint_c:g}" if self.ambient_hint_c is not None else None
        if hint is not None:
            self.screen.note(f"(rehearsal: the simulated shop is at {hint} °C)")
        return self._ask(key, question, temperature, hint, unset="not measured")

    def _identify(self, indicator: Indicator) -> dict[str, Any]:
        serial = self._ask(f"serial of {indicator.gauges}", f"Serial number of {indicator.label}",
                           str, default=indicator.serial or None, unset="not recorded")
        return self._identity(indicator, serial, " is new: its make, model and calibration "
                                                 "certificate (Enter: not recorded).")

    def _identity(self, indicator: Indicator, serial: str, asking: str,
                  usable: Callable[[KnownGauge], bool] = lambda known: True) -> dict[str, Any]:
        """The identity of the gauge ``serial`` names: met before (and ``usable``), or
        asked (``asking`` said after the serial) and confirmed; none without a serial."""
        if not serial:
            return {}
        known = self._known(serial)
        if known is not None and usable(known):
            self.screen.ok(f"{serial}: {known.summary()}")
            return known.identity()
        self.screen.say(f"{shown(serial)}{asking}")
        return self._confirmed(self._new_gauge(serial, known), indicator, usable).identity()

    def _known(self, serial: str) -> KnownGauge | None:
        """The gauge of this serial met before (or a rehearsal's simulated one)."""
        return self.known.get(serial) or self.inventory.find(serial)

    def _confirmed(self, gauge: KnownGauge, indicator: Indicator,
                   usable: Callable[[KnownGauge], bool] = lambda known: True) -> KnownGauge:
        """A new gauge shown whole and confirmed before instruments.toml remembers it; a
        serial typed again may be a gauge met before (the typo was in the serial): that
        one is taken as known (when ``usable``), never overwritten by the typo's answers."""
        s = self.screen
        while True:
            s.say(f"  {shown(gauge.serial)}: {shown(gauge.summary())}")
            if s.confirm("  Is this right? It is remembered for the next campaigns "
                         "(n: type it again)"):
                self.inventory.remember(gauge)
                return gauge
            serial = ""
            while not serial:
                serial = s.ask(f"Serial number of {indicator.label}", gauge.serial)
            known = self._known(serial)
            if known is not None and usable(known):
                s.ok(f"{serial}: {known.summary()}")
                return known
            gauge = self._new_gauge(serial, gauge)

    def _new_gauge(self, serial: str, typed: KnownGauge | None = None) -> KnownGauge:
        """A gauge's identity and certificate, asked (``typed``: the answers to offer
        again)."""
        s = self.screen
        before = typed or KnownGauge(serial)

        def offered(value: object) -> str | None:
            return None if value in (None, "") else str(value)

        def ask(what: str, question: str, parse: Callable[[str], T]) -> T:
            return self._ask(f"{serial} {what}", question, parse,
                             offered(getattr(before, what)))

        make = ask("make", "  Make", str)
        model = ask("model", "  Model", str)
        certificate = ask("certificate", "  Calibration certificate number", str)
        calibrated = ask("calibrated", "  Calibrated on (YYYY-MM-DD)", _date("calibrated"))
        while True:
            due = ask("due", "  Calibration due (YYYY-MM-DD)", _date("due"))
            if due is None or calibrated is None or due > calibrated:
                break
            s.problem(f"the due date must come after the calibration ({calibrated})")
        uncertainty, k = self._certificate_u(serial, certificate, before)
        return KnownGauge(serial, make=make, model=model, certificate=certificate,
                          calibrated=calibrated, due=due, uncertainty_mm=uncertainty,
                          uncertainty_k=k)

    def _certificate_u(self, serial: str, certificate: str, before: KnownGauge,
                       ) -> tuple[float | None, float | None]:
        """The certificate's U and k. A certificate given without its U is said plainly
        (the gauge's calibration then stays out of the uncertainty budget) and left so
        only when confirmed."""
        s = self.screen
        while True:
            uncertainty = self._ask(f"{serial} U", "  Certificate's expanded uncertainty U (mm)",
                                    _positive, None if before.uncertainty_mm is None
                                    else f"{before.uncertainty_mm:g}")
            if uncertainty is not None:
                default_k = f"{before.uncertainty_k:g}" if before.uncertainty_k else "2"
                return uncertainty, self._ask(f"{serial} k", "  Its coverage factor k",
                                              _coverage, default_k)
            if not certificate:
                return None, None
            s.problem("no U: without the certificate's expanded uncertainty this gauge's "
                      "calibration is left out of the uncertainty budget, and the record "
                      "says the budget is incomplete")
            if s.confirm("  Leave U unrecorded all the same?", default=False):
                return None, None

    def _check_due(self, trace: Traceability, indicators: Sequence[Indicator],
                   on: datetime.date) -> str:
        """A gauge past its due date: a reason to measure all the same, or re-identify
        it, or quit (OperatorQuit from the menu)."""
        s = self.screen
        while True:
            expired = expired_instruments(trace.instruments(0.0), on)
            if not expired:
                return ""
            for e in expired:
                s.problem(f"Gauge {e.describe()} is past the due date of its calibration "
                          f"certificate (today {on.isoformat()}).")
            choice = s.choose("What now?", [
                Option("o", "measure all the same (give the reason: it is recorded)"),
                Option("c", "change the gauge or correct its certificate"),
                Option("q", "quit (nothing was started)"),
            ], default="c")
            if choice == "o":
                return s.reason("measure with a gauge past its due date")
            if choice == "q":
                raise OperatorQuit("a gauge is past its due date")
            for indicator in indicators:
                if any(e.instrument.gauge in indicator.gauges for e in expired):
                    identity = self._reidentify(indicator, on)
                    for gauge in indicator.gauges:
                        trace.identities[gauge] = identity
            self.inventory.save()

    def _reidentify(self, indicator: Indicator, on: datetime.date) -> dict[str, Any]:
        """Another gauge, or the same with its new certificate."""
        serial = self.screen.ask(f"Serial number of {indicator.label}")
        return self._identity(indicator, serial, ": its calibration certificate.",
                              lambda gauge: gauge.due is None or gauge.due >= on)
