"""What a campaign records about itself besides its readings: who ran it on which
machine, when, with which instruments (and whether their certificates were still
valid), and at what temperature (docs/calibration-record.md 1-2).

The expired-gauge gate runs before the station opens: a gauge past its due date
on the campaign's date is refused before anything moves, unless the operator
states a reason, which is then recorded in the session (``OverrideRecord``).
"""

from __future__ import annotations

import datetime
from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any

from ogacq.campaign.campaign_file import Campaign, GaugeSpec
from ogacq.campaign.station import DeviceStation
from ogacq.errors import Refused
from ogacq.model.gauges import GAUGE_KEYS, gauges_on
from ogacq.model.instrument import Instrument
from ogacq.session.records import EnvironmentRecord, OverrideRecord

EXPIRED_GAUGE = "expired-gauge"


@dataclass(frozen=True)
class ExpiredInstrument:
    instrument: Instrument

    @property
    def subject(self) -> str:
        """How the override names it: "y_x 12345678"."""
        return f"{self.instrument.gauge} {self.instrument.serial or '(no serial)'}"

    def describe(self) -> str:
        """"y_x (serial 12345678, due 2026-01-01)"."""
        due = self.instrument.due.isoformat() if self.instrument.due else "?"
        serial = self.instrument.serial or "no serial"
        return f"{self.instrument.gauge} (serial {serial}, due {due})"


def expired_instruments(instruments: Iterable[Instrument], on: datetime.date,
                        ) -> list[ExpiredInstrument]:
    return [ExpiredInstrument(i) for i in instruments if i.expired(on)]


def check_instruments(campaign: Campaign, *, overridden: Iterable[str] = (),
                      ) -> list[OverrideRecord]:
    """Before anything opens: every gauge within its certificate on the campaign's
    date, or an override with its reason. Returns the overrides to record;
    ``Refused`` names each expired gauge, its serial and due date otherwise.
    ``overridden``: subjects a resumed session already recorded an override for."""
    on = campaign.campaign_date().date()
    already = set(overridden)
    expired = [e for e in expired_instruments(campaign.instruments(), on)
               if e.subject not in already]
    if not expired:
        return []
    if not campaign.override_expired:
        which = (f"gauge {expired[0].describe()} is" if len(expired) == 1 else
                 f"gauges {', '.join(e.describe() for e in expired)} are")
        raise Refused(f"{which} past the due date of the calibration certificate on the "
                      f"campaign's date {on.isoformat()}. Nothing was started: "
                      "have it recalibrated, or run it all the same with --override-expired "
                      "REASON (or [override] expired_gauges = \"REASON\" in the campaign file); "
                      "the reason is recorded")
    return [OverrideRecord(what=EXPIRED_GAUGE, subject=e.subject,
                           due=e.instrument.due.isoformat() if e.instrument.due else None,
                           reason=campaign.override_expired,
                           operator=campaign.operator or None) for e in expired]


def traceability_gaps(campaign: Campaign) -> list[str]:
    """What the campaign's record will lack, said before anything moves: no operator,
    a gauge of the plan without a calibration certificate, a certificate without its
    U and k (the uncertainty budget then leaves that gauge's calibration out and the
    record says it is incomplete: docs/calibration-record.md sections 1-3)."""
    gaps = []
    if not campaign.operator:
        gaps.append("no operator is named (operator = \"NAME\" in the campaign file): the "
                    "record will say the operator was not given")
    given = {i.gauge: i for i in campaign.instruments()}
    planned = [g.key for g in gauges_on(tuple(campaign.protocol.legs))]
    uncertified = [g for g in planned if g not in given or not given[g].certificate]
    without_u = [g for g in planned if g not in uncertified
                 and given[g].standard_uncertainty_mm is None]
    budget = ("left out of the uncertainty budget, which the record will mark incomplete")
    if uncertified:
        gaps.append(f"{_gauges(uncertified)} no calibration certificate ([[gauges]] "
                    f"certificate, uncertainty_mm, uncertainty_k): {_their(uncertified)} "
                    f"calibration is {budget}")
    if without_u:
        gaps.append(f"{_gauges(without_u)} a certificate without its expanded uncertainty "
                    f"([[gauges]] uncertainty_mm and uncertainty_k): {_their(without_u)} "
                    f"calibration is {budget}")
    return gaps


def _gauges(keys: list[str]) -> str:
    return f"gauge {keys[0]} has" if len(keys) == 1 else f"gauges {', '.join(keys)} have"


def _their(keys: list[str]) -> str:
    return "its" if len(keys) == 1 else "their"


def header_entries(campaign: Campaign, station_gauges: dict[str, Any]) -> dict[str, Any]:
    """The session header's ``identity``, ``instruments`` and ``date``: every gauge
    the station reads, with the identity the campaign gives it (or its serial)."""
    machine = campaign.machine
    given = {i.gauge: i for i in campaign.instruments(machine.gauge_resolution_mm)}
    instruments = []
    for key in dict.fromkeys([*station_gauges, *given]):
        instrument = given.get(key)
        if instrument is None:  # only what the station knows of it
            serial = str(station_gauges.get(key, {}).get("serial") or "") or None
            instrument = Instrument(key, serial=serial,
                                    resolution_mm=machine.gauge_resolution_mm)
        instruments.append(instrument.to_json())
    return {"identity": {"machine": machine.name or None, "serial": machine.serial or None,
                         "operator": campaign.operator or None},
            "instruments": instruments,
            "date": campaign.campaign_date().isoformat()}


def read_environment(campaign: Campaign, station: DeviceStation, stage: str,
                     ) -> EnvironmentRecord | None:
    """The temperatures at ``stage`` ("start" or "end"): read from the controller's
    registers when the campaign names that sensor, typed in the campaign file, or
    the simulator's shop; None when nothing says them."""
    env = campaign.environment
    if env is not None and env.sensor == "controller":
        read = station.controller.read_temperatures()
        return EnvironmentRecord(stage=stage, ambient_c=_rounded(read.get("ambient")),
                                 machine_c=_rounded(read.get("machine")), source="sensor")
    if env is not None and (env.ambient_c is not None or env.machine_c is not None):
        # typed once in the file: it says the start; the end is only what was measured
        if stage == "end":
            return None
        return EnvironmentRecord(stage=stage, ambient_c=env.ambient_c,
                                 machine_c=env.machine_c, source="typed")
    if station.simulator is not None:
        return EnvironmentRecord(stage=stage, ambient_c=station.simulator.ambient_c,
                                 machine_c=None, source="simulator")
    return None


def _rounded(value: float | None) -> float | None:
    return None if value is None else round(value, 3)


# The simulated indicators' certificate: issued CERTIFICATE_AGE_DAYS before today, valid
# a year, its U that of a 1 um digital indicator (k = 2). A --date past its due date
# rehearses the expired-gauge refusal.
CERTIFICATE_AGE_DAYS = 90
CERTIFICATE_VALID_DAYS = 365
SIMULATED_U_MM = 0.002


def simulated_gauges(today: datetime.date) -> list[GaugeSpec]:
    """The simulator's six indicators as instruments with a (simulated) certificate."""
    calibrated = today - datetime.timedelta(days=CERTIFICATE_AGE_DAYS)
    return [GaugeSpec(key, serial=f"sim-{key}", make="ogacq", model="simulated indicator",
                      certificate=f"SIM-{calibrated:%Y%m%d}-{key} (simulated)",
                      calibrated=calibrated,
                      due=calibrated + datetime.timedelta(days=CERTIFICATE_VALID_DAYS),
                      uncertainty_mm=SIMULATED_U_MM, uncertainty_k=2.0)
            for key in GAUGE_KEYS]
