"""Indicator drivers, picked by protocol name and imported lazily.

>>> gauge = open_indicator("mitutoyo-01a", "/dev/ttyUSB0", unit="mm", where="gauge A")
>>> read_stable(gauge, n=3, tolerance_mm=0.002, timeout_s=5).value_mm

``BACKENDS`` is the one table of gauge protocols: per protocol, a :class:`Backend`
naming its driver, its codec, its simulated instrument and the hints the wizard
shows (see :mod:`ogacq_drivers.indicators.backend`). The simulator, the wizard, the
fuzz tests and the check of the README's table iterate it. A part's
module is imported only when asked for, so a station without a given gauge never
imports its driver. A protocol defined outside this package is one more entry
(:func:`register`).
"""

from __future__ import annotations

import re
from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from types import MappingProxyType
from typing import Any

import serial

from ogacq_drivers.errors import DriverError
from ogacq_drivers.indicators.backend import Backend, Codec, ConnectionHints, load
from ogacq_drivers.indicators.base import Indicator, Reading, StableReading, read_stable
from ogacq_drivers.link import LinkSettings, open_link

__all__ = ["BACKENDS", "DEFAULT_PROTOCOL", "Backend", "ConnectionHints", "Indicator", "Reading",
           "StableReading", "backend", "codec", "driver_class", "open_indicator", "read_stable",
           "register", "registered", "same_indicator", "unregister"]

_SERIAL_PORTS = "a serial device (/dev/ttyUSB0, COM3) or a network port (socket://host:port)"

_BUILT_IN: dict[str, Backend] = {
    "mitutoyo-01a": Backend(
        "Mitutoyo 01A ASCII on a serial port (DMX-1, MUX-10, QM-Height)",
        driver="ogacq_drivers.indicators.mitutoyo_01a:Mitutoyo01A",
        codec="ogacq_drivers.indicators.mitutoyo_01a:CODEC",
        simulator="ogacq_drivers.sim.mitutoyo_01a:Mitutoyo01ADevice",
        hints=ConnectionHints(_SERIAL_PORTS, channel="a multiplexer's channel (1-9, A-Z)"),
        settings=LinkSettings(baudrate=9600, bytesize=8, parity="N", stopbits=1),
        same_indicator="ogacq_drivers.indicators.mitutoyo_01a:same_indicator",
    ),
    "digimatic": Backend(
        "raw Digimatic frames from a USB bridge (polled or streaming)",
        driver="ogacq_drivers.indicators.digimatic:DigimaticBridge",
        codec="ogacq_drivers.indicators.digimatic:CODEC",
        simulator="ogacq_drivers.sim.digimatic:DigimaticBridgeDevice",
        hints=ConnectionHints(_SERIAL_PORTS + "; a USB bridge is a virtual COM port"),
        # USB bridges are virtual COM ports: the rate is ignored but must be valid.
        settings=LinkSettings(baudrate=9600, bytesize=8, parity="N", stopbits=1),
    ),
    "uwave": Backend(
        "Mitutoyo U-WAVE-R receiver (pushed readings)",
        driver="ogacq_drivers.indicators.uwave:UWaveReceiver",
        codec="ogacq_drivers.indicators.uwave:CODEC",
        simulator="ogacq_drivers.sim.uwave:UWaveReceiverDevice",
        hints=ConnectionHints(
            _SERIAL_PORTS,
            note="U-WAVE sends a value when the transmitter's DATA button is pressed: "
                 "press it when a gauge is tested.",
            channel="the transmitter: CC, or GGCC with its group"),
        settings=LinkSettings(baudrate=57600, bytesize=8, parity="N", stopbits=1),
        same_indicator="ogacq_drivers.indicators.uwave:same_indicator",
    ),
    "sylvac": Backend(
        "Sylvac Opto-RS duplex cable",
        driver="ogacq_drivers.indicators.sylvac:SylvacOptoRS",
        codec="ogacq_drivers.indicators.sylvac:CODEC",
        simulator="ogacq_drivers.sim.sylvac:SylvacDuplexDevice",
        hints=ConnectionHints(_SERIAL_PORTS),
        settings=LinkSettings(baudrate=4800, bytesize=7, parity="E", stopbits=2, dtr=True,
                              rts=False),
    ),
    "sylvac-simplex": Backend(
        "Sylvac Opto-RS simplex cable (DTR-pulse request; real port or rfc2217://)",
        driver="ogacq_drivers.indicators.sylvac_simplex:SylvacSimplex",
        codec="ogacq_drivers.indicators.sylvac:CODEC",  # the duplex cable's frames
        simulator="ogacq_drivers.sim.sylvac:SylvacSimplexDevice",
        hints=ConnectionHints(
            "a real serial port (/dev/ttyUSB0, COM3) or an RFC 2217 server "
            "(rfc2217://host:port): a pseudo-terminal or a raw socket has no DTR",
            note="Sylvac simplex cable: it needs a real serial port (or an RFC 2217 "
                 "server) with DTR and RTS; ogacq asks for each value with a DTR pulse."),
        # Powered from RTS high; DTR rests high and a low pulse asks for a value.
        settings=LinkSettings(baudrate=4800, bytesize=7, parity="E", stopbits=2, dtr=True,
                              rts=True),
    ),
    "usb-itn": Backend(
        "Mitutoyo USB-ITN cable in data mode (pyusb; port usb, usb:SERIAL)",
        driver="ogacq_drivers.indicators.usb_itn:UsbItn",
        codec="ogacq_drivers.indicators.usb_itn:CODEC",
        simulator="ogacq_drivers.sim.usb_itn:UsbItnEndpoint",
        hints=ConnectionHints(
            "usb (the one cable), usb:SERIAL or usb:BUS.ADDRESS (lsusb shows them)",
            note="USB-ITN in data mode: ogacq switches the cable to data mode.",
            find="ogacq_drivers.indicators.usb_itn:find_cables"),
        kind="usb",
    ),
    "usb-itn-keyboard": Backend(
        "Mitutoyo USB-ITN cable in keyboard mode (port keyboard or /dev/input/eventN)",
        driver="ogacq_drivers.indicators.usb_itn_keyboard:UsbItnKeyboard",
        codec="ogacq_drivers.indicators.usb_itn_keyboard:CODEC",
        simulator="ogacq_drivers.sim.keyboard:KeyboardEndpoint",
        hints=ConnectionHints(
            "keyboard (the cable, found by its USB ids) or /dev/input/eventN",
            note="USB-ITN in keyboard mode: press the cable's data switch when a gauge is "
                 "tested. The typed values go to ogacq only, not into other windows.",
            find="ogacq_drivers.indicators.usb_itn_keyboard:find_keyboards"),
        kind="input",
    ),
}
_REGISTRY: dict[str, Backend] = dict(_BUILT_IN)
#: Every protocol by name: the built-in ones, then those registered.
BACKENDS: Mapping[str, Backend] = MappingProxyType(_REGISTRY)
#: What a gauge speaks unless told (campaign files, the simulator, the wizard).
DEFAULT_PROTOCOL = "mitutoyo-01a"
_NAME = re.compile(r"[a-z0-9][a-z0-9-]*")


def register(name: str, entry: Backend) -> None:
    """Add a protocol to ``BACKENDS`` (a plugin's, a test's). ValueError for a name
    taken or not lower-case letters, digits and hyphens."""
    if not _NAME.fullmatch(name):
        raise ValueError(f"a protocol name is lower-case letters, digits and '-', got {name!r}")
    if name in _REGISTRY:
        raise ValueError(f"protocol {name!r} is already registered")
    _REGISTRY[name] = entry


def unregister(name: str) -> None:
    """Remove a registered protocol; the built-in ones stay."""
    if name in _BUILT_IN:
        raise ValueError(f"{name!r} is built in")
    _REGISTRY.pop(name, None)


@contextmanager
def registered(name: str, entry: Backend) -> Iterator[Backend]:
    """``entry`` in ``BACKENDS`` as ``name`` for the duration of the block."""
    register(name, entry)
    try:
        yield entry
    finally:
        unregister(name)


def backend(protocol: str) -> Backend:
    """The table entry for ``protocol``; DriverError listing the known names if unknown."""
    try:
        return BACKENDS[protocol]
    except KeyError:
        known = ", ".join(sorted(BACKENDS))
        raise DriverError(f"unknown indicator protocol {protocol!r} (known: {known})") from None


def driver_class(protocol: str) -> type[Any]:
    """Import and return the driver class for ``protocol``."""
    cls: type[Any] = load(backend(protocol).driver)
    return cls


def codec(protocol: str) -> Codec:
    """Import and return the codec of ``protocol``."""
    found: Codec = load(backend(protocol).codec)
    return found


def same_indicator(protocol: str, a: str | None, b: str | None) -> bool:
    """Whether two gauges of ``protocol`` on one port, set to channels ``a`` and ``b``
    (None: not set), may read the same indicator: as the driver picks frames, not as
    the channels are spelled (01A's unset channel is channel 1; U-WAVE's ``02`` is
    group 00's ``0002`` too). A protocol without channels has one indicator per port."""
    entry = backend(protocol)
    if not entry.same_indicator:
        return True
    meet: bool = load(entry.same_indicator)(a, b)
    return meet


def open_indicator(protocol: str, port: str, *, unit: str, channel: str | None = None,
                   where: str | None = None, settings: LinkSettings | None = None,
                   link: serial.Serial | None = None, **options: Any) -> Indicator:
    """Open ``port`` with the protocol's serial settings and return its driver.

    ``unit`` is the unit the gauge displays ("mm" or "inch"), recorded at
    setup; ``channel`` the multiplexer channel (01A) or transmitter (U-WAVE);
    ``where`` names the gauge in every error (default: the port). ``settings``
    overrides the protocol's serial settings; ``link`` reuses an open link
    (several channels of one multiplexer), which the driver then does not own.
    Other keyword ``options`` go to the driver (``timeout_s``, ``decimals``,
    ``mode="streaming"`` for Digimatic...)."""
    entry = backend(protocol)
    where = where or f"{protocol} gauge on {port}"
    cls = driver_class(protocol)
    if channel is not None:
        options["channel"] = channel
    if not entry.serial:
        if link is not None:
            raise DriverError(f"a {protocol} gauge opens its own device, not a serial link",
                              where=where)
        opened: Indicator = cls.open(port, where=where, unit=unit, **options)
        return opened
    owns_link = link is None
    if link is None:
        link = open_link(port, settings or entry.settings, where=where)
    try:
        indicator: Indicator = cls(link, where=where, unit=unit, owns_link=owns_link, **options)
        return indicator
    except BaseException:
        if owns_link:
            link.close()
        raise
