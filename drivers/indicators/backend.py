"""What a gauge protocol is made of: the parts one entry of ``BACKENDS`` names.

A protocol is one :class:`Backend`, which carries

- ``driver``: the class a station reads the gauge with (the
  :class:`~ogacq_drivers.indicators.base.Indicator` protocol);
- ``codec``: a :class:`Codec`, its frames both ways without any I/O, with the example
  frames of the documents it was written from (:class:`Example`) as test vectors;
- ``simulator``: the simulated instrument's side of the wire, which the simulator
  serves; only :mod:`ogacq_drivers.sim` loads it (``simulated_gauge``), so the
  drivers never import a simulator;
- ``hints`` (:class:`ConnectionHints`), ``settings`` and ``kind``: what the wizard
  shows, the serial line, and whether the driver opens a serial link or its own device.

Parts are named ``"module:attribute"`` and imported when first used (:func:`load`),
as python-can's table does: a station with no gauge of a protocol never imports its
modules, and a protocol defined elsewhere (a plugin, a test) is one more entry
(:func:`ogacq_drivers.indicators.register`).
"""

from __future__ import annotations

import importlib
import re
from dataclasses import dataclass, field
from decimal import Decimal
from typing import Any, Literal, Protocol

from ogacq_drivers.errors import DriverError
from ogacq_drivers.indicators.base import Unit, to_mm
from ogacq_drivers.link import LinkSettings

Kind = Literal["serial", "usb", "input"]
KINDS: tuple[Kind, ...] = ("serial", "usb", "input")
_PART = re.compile(r"[A-Za-z_][\w.]*:[A-Za-z_]\w*")


@dataclass(frozen=True, slots=True)
class Decoded:
    """The value one frame spells, in the unit the gauge displays."""

    value: Decimal
    decimals: int
    unit: Unit | None  # None: the frame has no unit field; the unit set at setup applies
    channel: str = ""

    def value_mm(self, configured: Unit = "mm") -> float:
        """The value in mm: from the frame's unit, or ``configured`` when it has none."""
        return to_mm(self.value, self.unit or configured)


@dataclass(frozen=True, slots=True)
class Example:
    """A frame from a document and what it means: one test vector of a codec.

    ``value_mm`` for a value frame (read with ``unit`` set at setup when the frame has
    no unit field); ``error`` for an error or status frame, the exception decoding it
    raises. ``source`` names the document, or says "no source" and why."""

    frame: bytes
    source: str
    value_mm: float | None = None
    error: type[DriverError] | None = None
    unit: Unit = "mm"

    def __post_init__(self) -> None:
        if (self.value_mm is None) == (self.error is None):
            raise ValueError(f"example {self.frame!r}: give a value_mm or an error, not both")
        if not self.source.strip():
            raise ValueError(f"example {self.frame!r}: name the document it is from")


class Decode(Protocol):
    def __call__(self, frame: bytes, *, where: str = "") -> Decoded: ...


class Encode(Protocol):
    def __call__(
        self, value: Decimal, *, decimals: int, unit: Unit = "mm", channel: str = ""
    ) -> bytes: ...


@dataclass(frozen=True, slots=True)
class Codec:
    """A protocol's frames both ways, pure: bytes in, bytes out.

    ``decode`` takes one whole frame (terminator included) and returns the value it
    spells, or raises a DriverError: FrameError for bytes off the grammar,
    DeviceFault/DeviceBusy for the device's error and status frames; never another
    exception, never a number the bytes do not spell (``tests/drivers`` fuzzes every
    codec of the table for this). ``encode`` is the frame a device sends for ``value``
    shown with ``decimals`` places (ValueError when it does not fit; ``channel`` ""
    is the protocol's first). ``fixed_width``: every value frame of the grammar has one
    length, so that a lost byte is always a grammar error."""

    decode: Decode
    encode: Encode
    examples: tuple[Example, ...]
    fixed_width: bool

    def __post_init__(self) -> None:
        if not self.examples:
            raise ValueError("a codec needs the example frames of its documents as test vectors")


@dataclass(frozen=True, slots=True)
class FoundPort:
    """A device of the protocol attached now, as a ``hints.find`` function lists it."""

    port: str
    description: str


@dataclass(frozen=True, slots=True)
class ConnectionHints:
    """What the wizard tells a technician connecting a gauge of the protocol.

    ``ports``: what the ``port`` of a campaign file may be; ``note``: what to do or
    know once the protocol is chosen; ``channel``: what a channel names, where the
    protocol has channels; ``find``: ``"module:function"`` returning the attached
    devices (:class:`FoundPort` list) that the system's list of serial ports does not
    show (USB and input devices), "" when that list is enough."""

    ports: str
    note: str = ""
    channel: str = ""
    find: str = ""

    def __post_init__(self) -> None:
        if not self.ports.strip():
            raise ValueError("say what the port of such a gauge may be")
        if self.find:
            _check_part("hints.find", self.find)


@dataclass(frozen=True, slots=True)
class Backend:
    """One gauge protocol: its parts (``"module:attribute"``, imported when used), the
    wizard's hints and its line.

    ``kind`` "serial": the driver class is built on an open serial link
    (``driver(link, where=, unit=, owns_link=, ...)``) opened with ``settings``;
    "usb" and "input": the driver opens its own device from the port string (its
    ``open`` class method), and ``settings`` is unused.

    ``same_indicator``: for a protocol with channels, a function ``(a, b) -> bool``
    saying whether gauges set to channels ``a`` and ``b`` (None: not set) of one port
    may read the same indicator, as its driver picks frames; "" for a protocol without
    channels, where every gauge on a port is the one indicator there."""

    description: str
    driver: str
    codec: str
    simulator: str
    hints: ConnectionHints
    settings: LinkSettings = field(default_factory=LinkSettings)
    kind: Kind = "serial"
    same_indicator: str = ""

    def __post_init__(self) -> None:
        if not self.description.strip():
            raise ValueError("describe the protocol (the wizard lists it)")
        for part in ("driver", "codec", "simulator"):
            _check_part(part, getattr(self, part))
        if self.same_indicator:
            _check_part("same_indicator", self.same_indicator)
        if self.kind not in KINDS:
            raise ValueError(f"kind must be one of {', '.join(KINDS)}, got {self.kind!r}")

    @property
    def serial(self) -> bool:
        return self.kind == "serial"

    @property
    def line(self) -> str:
        """The serial line as a technician sets it (``4800 7E2, DTR high, RTS low``);
        "" for a protocol that opens its own device."""
        if not self.serial:
            return ""
        s = self.settings
        text = f"{s.baudrate} {s.bytesize}{s.parity}{s.stopbits:g}"
        lines = [f"{name} {'high' if level else 'low'}"
                 for name, level in (("DTR", s.dtr), ("RTS", s.rts)) if level is not None]
        return ", ".join([text, *lines])


def _check_part(what: str, dotted: str) -> None:
    if not _PART.fullmatch(dotted):
        raise ValueError(f"{what} must be named 'package.module:attribute', got {dotted!r}")


def load(dotted: str) -> Any:
    """The object a part names: ``load("pkg.mod:Name")`` imports ``pkg.mod``."""
    module, _, attribute = dotted.partition(":")
    return getattr(importlib.import_module(module), attribute)
