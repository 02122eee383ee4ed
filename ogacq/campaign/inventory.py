"""The gauges the wizard has met, remembered by serial number, with their
certificates: ``instruments.toml`` in ogacq's data folder (``$OGACQ_HOME``, or
``~/.local/share/ogacq``). The next campaign offers them, so a technician types a
gauge's certificate once; the operator's name is remembered the same way.

The file is written whole or not at all (``write_atomically``); one that cannot
be read is named and left untouched (the wizard then remembers nothing new).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from ogacq_drivers.config_schema import Field, Table, TableArray, dump, text
from ogacq.campaign.campaign_file import CERTIFICATE_FIELDS, GaugeIdentity
from ogacq.io.atomic import write_atomically
from ogacq.io.data_folder import data_folder
from ogacq.io.errors import InputError
from ogacq.io.toml_file import load_toml

INVENTORY_NAME = "instruments.toml"


@dataclass(frozen=True)
class KnownGauge(GaugeIdentity):
    """A gauge as remembered: its identity and its last certificate."""

    serial: str

    def summary(self) -> str:
        """"Mitutoyo 543-790B, certificate DKD-K-12345, calibrated 2026-03-01, due
        2027-03-01, U = 0.0015 mm (k = 2)"; what is not known is left out."""
        parts = [" ".join(p for p in (self.make, self.model) if p) or "make not recorded"]
        if self.certificate:
            parts.append(f"certificate {self.certificate}")
        if self.calibrated:
            parts.append(f"calibrated {self.calibrated.isoformat()}")
        parts.append(f"due {self.due.isoformat()}" if self.due else "no due date")
        if self.uncertainty_mm is not None:
            k = f" (k = {self.uncertainty_k:g})" if self.uncertainty_k else ""
            parts.append(f"U = {self.uncertainty_mm:g} mm{k}")
        return ", ".join(parts)


_KNOWN_GAUGE = Table((Field("serial", text(), required=True), *CERTIFICATE_FIELDS),
                     build=KnownGauge)

INVENTORY_FILE = Table((
    Field("operator", text()),  # the last operator, offered first next time
    Field("gauges", TableArray(_KNOWN_GAUGE)),
))


@dataclass
class Inventory:
    path: Path
    operator: str = ""
    gauges: dict[str, KnownGauge] = field(default_factory=dict)  # by serial
    writable: bool = True  # False when the file on disk could not be read

    def find(self, serial: str) -> KnownGauge | None:
        return self.gauges.get(serial)

    def remember(self, gauge: KnownGauge) -> None:
        self.gauges[gauge.serial] = gauge

    def save(self) -> None:
        if not self.writable:
            return
        self.path.parent.mkdir(parents=True, exist_ok=True)
        text_ = dump(INVENTORY_FILE, {"operator": self.operator or None,
                                      "gauges": sorted(self.gauges.values(),
                                                       key=lambda g: g.serial)},
                     header="The gauges `ogacq wizard` has met, by serial number, with their "
                            "certificates\n(edit freely: the wizard offers them by serial).")
        write_atomically(self.path, text_.encode("utf-8"))


def load_inventory(path: Path | None = None) -> Inventory:
    """The inventory on disk (an empty one when there is none yet); an InputError
    names a file that cannot be read, with its line."""
    path = path or data_folder() / INVENTORY_NAME
    if not path.exists():
        return Inventory(path)
    given, source = load_toml(path, INVENTORY_FILE, "the instruments inventory")
    known: dict[str, KnownGauge] = {}
    for k, gauge in enumerate(given.get("gauges", [])):
        if gauge.serial in known:  # which one the wizard would offer is not for us to guess
            first = [g.serial for g in known.values()].index(gauge.serial)
            raise InputError(path, f"serial {gauge.serial!r} twice (gauges[{first}] at line "
                             f"{source.line(('gauges', first, 'serial'))}): one entry a gauge; "
                             "delete the one that is out of date",
                             source.line(("gauges", k, "serial")))
        known[gauge.serial] = gauge
    return Inventory(path, given.get("operator", ""), known)


def unreadable_inventory(path: Path | None = None) -> Inventory:
    """An inventory that remembers nothing and never overwrites the broken file."""
    return Inventory(path or data_folder() / INVENTORY_NAME, writable=False)
