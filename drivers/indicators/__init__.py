"""Indicator drivers, picked by protocol name and imported lazily.

>>> gauge = open_indicator("mitutoyo-01a", "/dev/ttyUSB0", unit="mm", where="gauge A")
>>> read_stable(gauge, n=3, tolerance_mm=0.002, timeout_s=5).value_mm

The table says, per protocol, which module and class implement it and the
serial settings its devices use; a backend module is imported only when asked
for, so a station without a given gauge never imports its driver.
"""

from __future__ import annotations

import importlib
from collections.abc import Mapping
from dataclasses import dataclass
from types import MappingProxyType
from typing import Any

import serial

from ogacq_drivers.errors import DriverError
from ogacq_drivers.indicators.base import Indicator, Reading, StableReading, read_stable
from ogacq_drivers.link import LinkSettings, open_link

__all__ = [
    "BACKENDS",
    "DEFAULT_PROTOCOL",
    "Backend",
    "Indicator",
    "Reading",
    "StableReading",
    "driver_class",
    "open_indicator",
    "read_stable",
]


@dataclass(frozen=True, slots=True)
class Backend:
    """Where a protocol's driver lives and how its link is set up.

    ``kind`` "serial": the driver gets an open serial link (``settings``);
    "usb" and "input": the driver class opens its own device from the port string
    (its ``open`` class method), and ``settings`` is unused.
    """

    module: str
    class_name: str
    settings: LinkSettings
    description: str
    kind: str = "serial"

    @property
    def serial(self) -> bool:
        return self.kind == "serial"


BACKENDS: Mapping[str, Backend] = MappingProxyType(
    {
        "mitutoyo-01a": Backend(
            "ogacq_drivers.indicators.mitutoyo_01a",
            "Mitutoyo01A",
            LinkSettings(baudrate=9600, bytesize=8, parity="N", stopbits=1),
            "Mitutoyo 01A ASCII on a serial port (DMX-1, MUX-10, QM-Height)",
        ),
        "digimatic": Backend(
            "ogacq_drivers.indicators.digimatic",
            "DigimaticBridge",
            # USB bridges are virtual COM ports: the rate is ignored but must be valid.
            LinkSettings(baudrate=9600, bytesize=8, parity="N", stopbits=1),
            "raw Digimatic frames from a USB bridge (polled or streaming)",
        ),
        "uwave": Backend(
            "ogacq_drivers.indicators.uwave",
            "UWaveReceiver",
            LinkSettings(baudrate=57600, bytesize=8, parity="N", stopbits=1),
            "Mitutoyo U-WAVE-R receiver (pushed readings)",
        ),
        "sylvac": Backend(
            "ogacq_drivers.indicators.sylvac",
            "SylvacOptoRS",
            LinkSettings(baudrate=4800, bytesize=7, parity="E", stopbits=2, dtr=True, rts=False),
            "Sylvac Opto-RS duplex cable",
        ),
        "sylvac-simplex": Backend(
            "ogacq_drivers.indicators.sylvac_simplex",
            "SylvacSimplex",
            # Powered from RTS high; DTR rests high and a low pulse asks for a value.
            LinkSettings(baudrate=4800, bytesize=7, parity="E", stopbits=2, dtr=True, rts=True),
            "Sylvac Opto-RS simplex cable (DTR-pulse request; real port or rfc2217://)",
        ),
        "usb-itn": Backend(
            "ogacq_drivers.indicators.usb_itn",
            "UsbItn",
            LinkSettings(),
            "Mitutoyo USB-ITN cable in data mode (pyusb; port usb, usb:SERIAL)",
            kind="usb",
        ),
        "usb-itn-keyboard": Backend(
            "ogacq_drivers.indicators.usb_itn_keyboard",
            "UsbItnKeyboard",
            LinkSettings(),
            "Mitutoyo USB-ITN cable in keyboard mode (port keyboard or /dev/input/eventN)",
            kind="input",
        ),
    }
)
#: What a gauge speaks unless told (campaign files, the simulator, the wizard).
DEFAULT_PROTOCOL = "mitutoyo-01a"


def backend(protocol: str) -> Backend:
    """The table entry for ``protocol``; DriverError listing the known names if unknown."""
    try:
        return BACKENDS[protocol]
    except KeyError:
        known = ", ".join(sorted(BACKENDS))
        raise DriverError(f"unknown indicator protocol {protocol!r} (known: {known})") from None


def driver_class(protocol: str) -> type[Any]:
    """Import and return the driver class for ``protocol``."""
    entry = backend(protocol)
    module = importlib.import_module(entry.module)
    return getattr(module, entry.class_name)


def open_indicator(
    protocol: str,
    port: str,
    *,
    unit: str,
    channel: str | None = None,
    where: str | None = None,
    settings: LinkSettings | None = None,
    link: serial.SerialBase | None = None,
    **options: Any,
) -> Indicator:
    """Open ``port`` with the protocol's serial settings and return its driver.

    ``unit`` is the unit the gauge displays ("mm" or "inch"), recorded at
    setup; ``channel`` the multiplexer channel (01A) or transmitter (U-WAVE);
    ``where`` names the gauge in every error (default: the port). ``settings``
    overrides the protocol's serial settings; ``link`` reuses an open link
    (several channels of one multiplexer), which the driver then does not own.
    Other keyword ``options`` go to the driver (``timeout_s``, ``decimals``,
    ``mode="streaming"`` for Digimatic...).
    """
    entry = backend(protocol)
    where = where or f"{protocol} gauge on {port}"
    cls = driver_class(protocol)
    if channel is not None:
        options["channel"] = channel
    if not entry.serial:
        if link is not None:
            raise DriverError(
                f"a {protocol} gauge opens its own device, not a serial link", where=where
            )
        return cls.open(port, where=where, unit=unit, **options)
    owns_link = link is None
    if link is None:
        link = open_link(port, settings or entry.settings, where=where)
    try:
        return cls(link, where=where, unit=unit, owns_link=owns_link, **options)
    except BaseException:
        if owns_link:
            link.close()
        raise
