"""Simulated gauges that speak the exact indicator wire formats.

Every protocol of ``BACKENDS`` names its simulated instrument (the backend's
``simulator``), and :func:`simulated_gauge` makes one of any protocol: the
simulator's stack knows no protocol by name.

A serial protocol's instrument is a :class:`SerialDevice` (what it answers, pushes
and shows; ``ogacq_drivers.sim.mitutoyo_01a``, ``.digimatic``, ``.uwave``,
``.sylvac``), served by a :class:`GaugeEndpoint`, which does the line for every
one of them: a real pseudo-terminal (clients open the slave path like a
``/dev/ttyUSB``), a loopback TCP socket (``socket://127.0.0.1:PORT``) or an RFC 2217
server (``rfc2217://127.0.0.1:PORT``), the one of the three that carries the
control lines (pyserial's own RFC 2217 port manager decodes the client's
SET_CONTROL requests here; a device that is asked by a control line, the Sylvac
simplex cable, is always served that way). Values come from ``value_source``
callables (the simulated machine, or a lambda in tests), are rounded to the
display resolution and encoded with the drivers' own encoders, so every end-to-end
test runs the real codecs.

Output is paced at the configured baud rate (10 or 11 bits per byte), and so
is input, because neither a pty nor a socket enforces a rate: a request/reply
exchange takes as long as on the real line.

Faults are switched at run time with :meth:`GaugeEndpoint.set_fault` (see
:class:`Fault`) so drivers can be shown to report each one clearly. The USB cables
(``ogacq_drivers.sim.usb_itn``, ``.keyboard``) are endpoints of their own, built on
:class:`UsbCableGauge`.
"""

from __future__ import annotations

import contextlib
import inspect
import logging
import math
import os
import queue
import select
import socket
import threading
import time
import tty
from collections.abc import Callable, Mapping
from dataclasses import dataclass, replace
from decimal import Decimal
from enum import StrEnum
from typing import Any, ClassVar, Literal, Protocol

from ogacq_drivers.indicators import BACKENDS, codec
from ogacq_drivers.indicators.backend import load
from ogacq_drivers.indicators.base import MM_PER_INCH as EXACT_MM_PER_INCH
from ogacq_drivers.indicators.base import Unit
from ogacq_drivers.link import LinkSettings
from ogacq_drivers.sim.clock import sleep_until
from ogacq_drivers.threads import leave_interrupts_to_the_main_thread

log = logging.getLogger(__name__)

ValueSource = Callable[[], float]
Transport = Literal["pty", "socket", "rfc2217"]
TRANSPORTS: tuple[Transport, ...] = ("pty", "socket", "rfc2217")
MM_PER_INCH = float(EXACT_MM_PER_INCH)  # the drivers' inch, for the simulated values

# Shortest DTR-low pulse the simulated Sylvac simplex instrument takes as a request
# (Opto-RS manual: 110 ms). Its device (ogacq_drivers.sim.sylvac) reads it from here
# when a pulse ends, so that a test can lengthen it and "too short" does not depend on
# how busy the machine is (tests/drivers/test_sylvac_simplex.py).
_SIMPLEX_PULSE_S = 0.110


class Fault(StrEnum):
    """Faults a simulated gauge can be told to show.

    Per reply (``count`` replies, or until cleared when ``count`` is None):
    ``silence`` (no answer), ``error`` (the protocol's error frame, ``code``:
    01A ``911``.., Sylvac ``3``/``ERR3``, U-WAVE status ``04``..), ``busy``
    (01A ``918``), ``garbled`` (a byte of the frame replaced), ``split`` (the
    frame sent in two parts ``pause_s`` apart), ``unplug`` (half a frame, then
    the device disappears: pty master closed / connection dropped).
    One-shot: ``stale`` (``count`` frames of an old value pushed into the line
    at once, as a bridge's buffer would hold them). State: ``inch`` (display in
    inch; ``code`` "1" or "8" picks the Digimatic unit nibble)."""

    SILENCE = "silence"
    ERROR = "error"
    BUSY = "busy"
    GARBLED = "garbled"
    SPLIT = "split"
    STALE = "stale"
    INCH = "inch"
    UNPLUG = "unplug"


@dataclass
class _FaultState:
    code: str = ""
    remaining: int | None = None  # replies still affected; None = until cleared
    pause_s: float = 0.05


class SimulatedGauge:
    """What every simulated gauge endpoint (serial, USB, keyboard) shares: the
    protocol it speaks and the ``port`` a client opens once it is started, used as a
    context manager around ``start``/``close``, and a table of the faults it has
    been told to show, guarded by ``_lock``."""

    protocol: str
    name: str
    _faults: dict[Fault, Any]
    _lock: Any  # a Lock or a Condition

    @property
    def port(self) -> str:
        """What a client opens; RuntimeError before :meth:`start`."""
        port = self._started_port()
        if not port:
            raise RuntimeError(f"{self.name}: start() the endpoint before asking for its port")
        return port

    def _started_port(self) -> str:
        """The port once started, "" before."""
        raise NotImplementedError

    def start(self) -> Any:
        raise NotImplementedError

    def set_fault(self, kind: Fault | str, *, code: str = "", count: int | None = None) -> None:
        """Switch a fault on (see :class:`Fault`); ValueError for one it cannot show."""
        raise NotImplementedError

    def close(self) -> None:
        raise NotImplementedError

    def __enter__(self) -> Any:
        return self.start()

    def __exit__(self, *exc_info: object) -> None:
        self.close()

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self._started_port() or 'not started'})"

    def clear_fault(self, kind: Fault | str | None = None) -> None:
        """Switch one fault off, or all of them."""
        with self._lock:
            if kind is None:
                self._faults.clear()
            else:
                self._faults.pop(Fault(kind), None)


class UsbCableGauge(SimulatedGauge):
    """A gauge behind a USB cable (USB-ITN data or keyboard mode): faults switch on
    per reply, except a pulled cable and a burst of old values, which happen at once.
    A subclass says which faults it can show and how a value is pushed."""

    CABLE = ""  # for messages: "a USB-ITN cable"
    SHOWS: tuple[Fault, ...] = ()
    #: Sends a value per press of its data switch (the stack's operator presses it).
    PRESSED = False
    MAX_DECIMALS = 6  # the 01A reply's 8 characters (the keyboard cable types the same)
    NAME = ""  # when given none

    def __init__(self, value_source: Callable[[], float], *, resolution_mm: float = 0.001,
                 unit: Unit = "mm", name: str | None = None) -> None:
        self.value_source = value_source
        self.resolution_mm = resolution_mm
        self.unit: Unit = unit
        self.name = name or self.NAME
        self.unplugged = False
        self._faults: dict[Fault, list[Any]] = {}  # kind -> [code, remaining or None]
        self._lock = threading.Lock()
        self._last_value_mm: float | None = None

    @classmethod
    def simulate(cls, protocol: str, source: ValueSource, setup: SimSetup) -> Any:
        """The stack's cable (served its own way whatever the setup's transport), its
        data switch, if it has one, pressed every ``setup.push_period_s``."""
        pressed: dict[str, Any] = {"period_s": setup.push_period_s} if cls.PRESSED else {}
        endpoint = cls(source, resolution_mm=setup.resolution_mm, name=setup.name, **pressed)
        endpoint.protocol = protocol
        return endpoint

    def unplug(self) -> None:
        raise NotImplementedError

    def _push_stale(self, value_mm: float, count: int) -> None:
        raise NotImplementedError

    def _fault_code(self, kind: Fault, code: str) -> str:
        """The code a fault is shown with, checked now (not at the next reply)."""
        return code

    def set_fault(self, kind: Fault | str, *, code: str = "", count: int | None = None) -> None:
        kind = Fault(kind)
        if kind is Fault.UNPLUG:
            self.unplug()
            return
        if kind is Fault.STALE:
            last = self._last_value_mm
            self._push_stale(last if last is not None else self.value_source(), count or 3)
            return
        if kind not in self.SHOWS:
            raise ValueError(f"{self.CABLE} cannot show {kind}")
        code = self._fault_code(kind, code)
        with self._lock:
            self._faults[kind] = [code, count]

    def _take_faults(self) -> dict[Fault, str]:
        """The faults applying to this reply, with their codes; counts are consumed
        (the inch display is a state, not a count of replies)."""
        with self._lock:
            taken = {}
            for kind, state in list(self._faults.items()):
                taken[kind] = state[0]
                if state[1] is not None and kind is not Fault.INCH:
                    state[1] -= 1
                    if state[1] <= 0:
                        del self._faults[kind]
            return taken

    def _shown_now(self, faults: Mapping[Fault, str]) -> tuple[Decimal, int]:
        """The value the gauge shows now (in inch under ``Fault.INCH``), remembered for
        a burst of old values."""
        value = float(self.value_source())
        self._last_value_mm = value
        return self._shown(value, "inch" if Fault.INCH in faults else self.unit)

    def _shown(self, value_mm: float, unit: Unit) -> tuple[Decimal, int]:
        return shown_value(value_mm, unit, self.resolution_mm, self.MAX_DECIMALS)


class _PtyTransport:
    """The master side of a pseudo-terminal; clients open the slave path."""

    def __init__(self) -> None:
        master, slave = os.openpty()
        # Raw before any client configures it: no echo of our frames back to us.
        tty.setraw(slave)
        os.set_blocking(master, False)
        self._master: int | None = master
        # Holding the slave open keeps the master from reading EIO whenever no
        # client has the port open (between test cases, before the first open).
        self._slave: int | None = slave
        self.port = os.ttyname(slave)

    def input_fds(self) -> list[int]:
        return [] if self._master is None else [self._master]

    def on_readable(self, fd: int) -> bytes:
        try:
            return os.read(fd, 4096)
        except OSError:
            return b""

    def send(self, data: bytes) -> None:
        if self._master is None:
            return
        try:
            written = os.write(self._master, data)
        except BlockingIOError:
            written = 0
        except OSError:
            return
        if written < len(data):
            log.debug("pty %s full: dropped %d bytes nobody read", self.port, len(data) - written)

    def unplug(self) -> None:
        for fd in (self._master, self._slave):
            if fd is not None:
                with contextlib.suppress(OSError):
                    os.close(fd)
        self._master = self._slave = None

    close = unplug


class _SocketTransport:
    """A TCP listener on 127.0.0.1 serving one client at a time."""

    def __init__(self) -> None:
        listener = socket.create_server(("127.0.0.1", 0), backlog=1)
        listener.setblocking(False)
        self._listener: socket.socket | None = listener
        self._conn: socket.socket | None = None
        self.port = f"socket://127.0.0.1:{listener.getsockname()[1]}"

    def input_fds(self) -> list[int]:
        if self._conn is not None:
            return [self._conn.fileno()]
        return [] if self._listener is None else [self._listener.fileno()]

    def on_readable(self, fd: int) -> bytes:
        if self._conn is None:
            if self._listener is not None:
                with contextlib.suppress(BlockingIOError):
                    conn, _ = self._listener.accept()
                    conn.setblocking(False)
                    # Bytes go out one by one at the line rate: no Nagle batching.
                    conn.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
                    self._conn = conn
            return b""
        try:
            data = self._conn.recv(4096)
        except BlockingIOError:
            return b""
        except OSError:
            data = b""
        if not data:  # the client closed its end: wait for the next one
            self._drop_connection()
        return data

    def send(self, data: bytes) -> None:
        if self._conn is None:
            return
        try:
            written = self._conn.send(data)
        except BlockingIOError:
            written = 0
        except OSError:
            self._drop_connection()
            return
        if written < len(data):
            log.debug("socket %s full: dropped %d bytes", self.port, len(data) - written)

    def _drop_connection(self) -> None:
        if self._conn is not None:
            with contextlib.suppress(OSError):
                self._conn.close()
            self._conn = None

    def unplug(self) -> None:
        self._drop_connection()
        if self._listener is not None:
            with contextlib.suppress(OSError):
                self._listener.close()
            self._listener = None

    close = unplug


class _ControlLines:
    """The serial port pyserial's RFC 2217 PortManager drives: line settings are
    kept, and DTR/RTS changes are handed to the endpoint."""

    def __init__(self, on_change: Callable[[str, bool], None]) -> None:
        self._on_change = on_change
        self.baudrate, self.bytesize, self.parity, self.stopbits = 9600, 8, "N", 1
        self.rtscts = self.xonxoff = False
        self.break_condition = False
        self.cts = self.dsr = True
        self.ri = self.cd = False
        self._dtr = self._rts = False

    @property
    def dtr(self) -> bool:
        return self._dtr

    @dtr.setter
    def dtr(self, level: bool) -> None:
        self._dtr = level
        self._on_change("dtr", level)

    @property
    def rts(self) -> bool:
        return self._rts

    @rts.setter
    def rts(self, level: bool) -> None:
        self._rts = level
        self._on_change("rts", level)

    def reset_input_buffer(self) -> None:
        pass

    def reset_output_buffer(self) -> None:
        pass


class _Rfc2217Transport(_SocketTransport):
    """A loopback RFC 2217 server (a network serial port with control lines)."""

    def __init__(self, on_control: Callable[[str, bool], None]) -> None:
        super().__init__()
        self.port = self.port.replace("socket://", "rfc2217://")
        self._on_control = on_control
        self._manager: Any = None

    def on_readable(self, fd: int) -> bytes:
        had_connection = self._conn is not None
        data = super().on_readable(fd)
        if not had_connection and self._conn is not None:
            from serial.rfc2217 import PortManager

            # pyserial documents duck types here (a port with the control lines, a
            # connection with write()); its stubs ask for Serial
            self._manager = PortManager(_ControlLines(self._on_control),  # type: ignore[arg-type]
                                        self)  # type: ignore[arg-type]
        if not data or self._manager is None:
            return b""
        return b"".join(self._manager.filter(data))

    def write(self, data: bytes) -> None:
        """PortManager's connection interface (Telnet negotiation, replies)."""
        if self._conn is not None:
            with contextlib.suppress(OSError):
                self._conn.sendall(data)

    def send(self, data: bytes) -> None:
        if self._manager is not None:
            data = b"".join(self._manager.escape(data))
        super().send(data)

    def _drop_connection(self) -> None:
        super()._drop_connection()
        self._manager = None


def _decimals_for(resolution: float, limit: int) -> int:
    """Decimal places needed to show steps of ``resolution``."""
    return max(0, min(limit, math.ceil(-math.log10(resolution) - 1e-9)))


def shown_value(value_mm: float, unit: Unit, resolution_mm: float,
                max_decimals: int) -> tuple[Decimal, int]:
    """What a display of ``resolution_mm`` steps shows of ``value_mm`` in ``unit``, and
    its decimal places: in mm, rounded to the step; in inch, as many places as the
    step needs in inch."""
    if unit == "mm":
        shown = Decimal(round(value_mm / resolution_mm)) * Decimal(str(resolution_mm))
        return shown, _decimals_for(resolution_mm, max_decimals)
    return (Decimal(repr(value_mm / MM_PER_INCH)),
            _decimals_for(resolution_mm / MM_PER_INCH, max_decimals))


def _garble(frame: bytes) -> bytes:
    """Replace the middle byte of the frame body with one no grammar accepts."""
    body = frame.rstrip(b"\r\n")
    index = len(body) // 2
    return body[:index] + b"#" + body[index + 1 :] + frame[len(body) :]


def transport_of(text: str) -> Transport:
    """``text`` as a transport name; ValueError for another."""
    for transport in TRANSPORTS:
        if text == transport:
            return transport
    raise ValueError(f"transport must be 'pty', 'socket' or 'rfc2217', got {text!r}")


@dataclass(frozen=True, slots=True)
class SimSetup:
    """What the simulator's stack asks of every gauge, whatever its protocol.

    ``transport``: how a serial gauge is served (a protocol may insist on its own);
    ``push_period_s``: how often the simulated operator presses the data button of a
    gauge that sends a value per press (U-WAVE, the keyboard cable), None for never;
    ``line_speed``: how many times faster than its baud rate a serial line runs (a
    rehearsal at ``speed`` asks for as much; 1: the real line)."""

    resolution_mm: float = 0.001
    transport: Transport = "pty"
    name: str | None = None
    push_period_s: float | None = None
    line_speed: float = 1.0


class SimulatedInstrument(Protocol):
    """What a backend's ``simulator`` names: a class that makes its simulated gauge."""

    def simulate(self, protocol: str, source: ValueSource, setup: SimSetup) -> SimulatedGauge:
        ...


def simulator_of(protocol: str) -> SimulatedInstrument:
    """The simulated instrument ``protocol``'s backend names; ValueError if unknown."""
    entry = BACKENDS.get(protocol)
    if entry is None:
        raise ValueError(f"unknown protocol {protocol!r} (known: {', '.join(BACKENDS)})")
    instrument: SimulatedInstrument = load(entry.simulator)
    return instrument


def simulated_gauge(protocol: str, source: ValueSource, setup: SimSetup) -> SimulatedGauge:
    """A simulated gauge of any protocol of ``BACKENDS``, not yet started."""
    return simulator_of(protocol).simulate(protocol, source, setup)


class SerialDevice:
    """The instrument's side of one serial protocol: what it answers, pushes and shows.

    A :class:`GaugeEndpoint` drives it: the endpoint does the line (transport, pacing
    at the baud rate), the faults and the serving thread, and asks the device only
    what the protocol decides. A serial protocol's backend names its subclass as the
    ``simulator``; options given to the endpoint (``streaming=True``) go to the
    subclass's constructor. Methods run in the endpoint's serving thread."""

    #: The channel a one-channel endpoint serves when none is given.
    DEFAULT_CHANNEL: ClassVar[str] = ""
    #: The most decimals its frames carry (every device says).
    MAX_DECIMALS: ClassVar[int]
    #: The one transport that carries the protocol (None: any).
    TRANSPORT: ClassVar[Transport | None] = None
    #: Sends frames unasked: every ``period_s`` and on :meth:`GaugeEndpoint.trigger`.
    FREE_RUNNING: ClassVar[bool] = False
    #: Sends a value per press of a data button (the stack's operator presses it).
    PRESSED: ClassVar[bool] = False
    #: The code ``Fault.ERROR`` shows when given none (None: no error frames).
    DEFAULT_ERROR: ClassVar[str | None] = None
    #: The code of the busy reply ``Fault.BUSY`` shows (None: the protocol has none).
    BUSY_CODE: ClassVar[str | None] = None

    def __init__(self, gauge: GaugeEndpoint) -> None:
        self.gauge = gauge

    @classmethod
    def simulate(cls, protocol: str, source: ValueSource, setup: SimSetup) -> GaugeEndpoint:
        """The stack's gauge of this protocol."""
        return GaugeEndpoint(protocol, source, resolution_mm=cls.shown_resolution_mm(
            setup.resolution_mm), transport=setup.transport, name=setup.name,
            period_s=setup.push_period_s if cls.PRESSED else None,
            line_speed=setup.line_speed)

    @classmethod
    def shown_resolution_mm(cls, resolution_mm: float) -> float:
        """The display step a gauge of this protocol shows in the stack for a machine
        whose gauges resolve ``resolution_mm``."""
        return resolution_mm

    @classmethod
    def check_channel(cls, channel: str) -> None:
        """ValueError when ``channel`` is not a channel of the protocol."""

    @property
    def default_period_s(self) -> float | None:
        """The output period when the endpoint is given none (None: no output unasked)."""
        return None

    def on_input(self, data: bytes) -> None:
        """Bytes from the client, once their line time is over (default: ignored)."""

    def on_control(self, line: str, level: bool) -> None:
        """A control line (``"dtr"``, ``"rts"``) changed (default: ignored)."""

    def value_frame(self, value: Decimal, *, decimals: int, unit: Unit, channel: str,
                    inch_code: str) -> bytes:
        """The frame showing ``value`` (display unit) with ``decimals`` places;
        ValueError when the display cannot show it. ``inch_code``: the unit code an
        inch display uses where the protocol has two (Digimatic's "1" or "8"). By
        default the protocol's codec encodes it, as the drivers decode it."""
        return codec(self.gauge.protocol).encode(value, decimals=decimals, unit=unit,
                                                 channel=channel)

    def overflow_frame(self) -> bytes | None:
        """What it sends for a value its display cannot show (None: nothing)."""
        return None

    def error_frame(self, code: str, channel: str) -> bytes:
        """The error or status frame ``code``; ValueError for a code it has not."""
        raise ValueError(f"{self.gauge.protocol} frames have no error code")


class LineDevice(SerialDevice):
    """A device that takes commands as lines ending in CR (an LF is ignored); each
    line counts as a request. Longer than 64 bytes without a CR: dropped."""

    def __init__(self, gauge: GaugeEndpoint) -> None:
        super().__init__(gauge)
        self._rx_buffer = bytearray()

    def on_input(self, data: bytes) -> None:
        self._rx_buffer += data.replace(b"\n", b"")
        while b"\r" in self._rx_buffer:
            line, _, rest = bytes(self._rx_buffer).partition(b"\r")
            self._rx_buffer = bytearray(rest)
            self.gauge.count_request()
            self.on_line(line.decode("ascii", "replace").strip())
        if len(self._rx_buffer) > 64:
            self._rx_buffer.clear()

    def on_line(self, command: str) -> None:
        """One command (stripped of blanks)."""
        raise NotImplementedError


class GaugeEndpoint(SimulatedGauge):
    """One simulated gauge (or 01A multiplexer / U-WAVE receiver) of a serial protocol
    on a pty, a socket or an RFC 2217 server.

    ``protocol`` names a serial backend; its :class:`SerialDevice` decides what is
    sent. ``value_source`` gives the true value in mm (noise included); a mapping
    ``{channel: source}`` serves several channels (01A multiplexer channels
    ``"1"``..; U-WAVE transmitters ``"GGCC"``). ``resolution_mm`` is the display
    resolution in mm; ``unit`` the display unit. ``baud`` (default: the protocol's)
    paces the bytes, ``line_speed`` times faster than it runs (an accelerated
    rehearsal's line: the same frames, each byte's time divided). A free-running
    device (Digimatic bridge, U-WAVE receiver) pushes a frame per channel every
    ``period_s`` if given, and on :meth:`trigger`. Other
    keyword ``options`` go to the device (Digimatic: ``streaming``, ``digimatic2``)."""

    def __init__(self, protocol: str, value_source: ValueSource | Mapping[str, ValueSource], *,
                 resolution_mm: float = 0.001, unit: Unit = "mm", channel: str | None = None,
                 baud: int | None = None, transport: Transport = "pty",
                 period_s: float | None = None, name: str | None = None, line_speed: float = 1.0,
                 **options: Any) -> None:
        device_class = simulator_of(protocol)
        if not (isinstance(device_class, type) and issubclass(device_class, SerialDevice)):
            raise ValueError(f"{protocol} is not served on a serial line: make its gauge "
                             "with simulated_gauge()")
        transport = transport_of(transport)
        transport = device_class.TRANSPORT or transport
        if unit not in ("mm", "inch"):
            raise ValueError(f"unit must be 'mm' or 'inch', got {unit!r}")
        if resolution_mm <= 0:
            raise ValueError(f"resolution_mm must be positive, got {resolution_mm}")
        self.protocol = protocol
        self.transport_kind: Transport = transport
        settings: LinkSettings = BACKENDS[protocol].settings
        if baud is not None:
            settings = replace(settings, baudrate=baud)
        if not line_speed > 0:
            raise ValueError(f"line_speed must be positive, got {line_speed}")
        self.settings = settings
        self.byte_time_s = settings.byte_time_s / line_speed
        if callable(value_source):
            self.channels: dict[str, ValueSource] = {
                channel if channel is not None else device_class.DEFAULT_CHANNEL: value_source}
        else:
            self.channels = dict(value_source)
            if not self.channels:
                raise ValueError("value_source mapping has no channels")
        for ident in self.channels:
            device_class.check_channel(ident)
        self.default_channel = channel if channel is not None else next(iter(self.channels))
        self.resolution_mm = resolution_mm
        self.unit: Unit = unit
        self.name = name or f"sim-{protocol}"

        self.requests_received = 0
        self.unplugged = False
        self._faults: dict[Fault, _FaultState] = {}
        self._lock = threading.Lock()
        self._commands: queue.SimpleQueue[tuple[Callable[[], None], threading.Event]]
        self._commands = queue.SimpleQueue()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._transport: _PtyTransport | _SocketTransport | None = None
        self._wake_r = self._wake_w = -1
        self._rx_free_at = 0.0
        self._tx_free_at = 0.0
        self._last_value_mm: dict[str, float] = {}

        try:
            inspect.signature(device_class).bind(self, **options)
        except TypeError:
            raise ValueError(f"a {protocol} gauge takes no option "
                             f"{', '.join(sorted(options))}") from None
        self.device: SerialDevice = device_class(self, **options)
        if period_s is None:
            period_s = self.device.default_period_s
        if period_s is not None and not device_class.FREE_RUNNING:
            raise ValueError(f"{protocol} answers requests; it has no output period")
        # A frame takes its line time whatever the period: a stream faster than
        # the line simply sends frames back to back.
        self.period_s = period_s

    # ----------------------------------------------------------------- lifecycle
    def _started_port(self) -> str:
        """The pty slave path, ``socket://127.0.0.1:PORT`` or ``rfc2217://127.0.0.1:PORT``."""
        return "" if self._transport is None else self._transport.port

    def start(self) -> GaugeEndpoint:
        """Create the pty or socket and start serving in a daemon thread."""
        if self._thread is not None:
            return self
        if self.transport_kind == "pty":
            self._transport = _PtyTransport()
        elif self.transport_kind == "rfc2217":
            self._transport = _Rfc2217Transport(self.device.on_control)
        else:
            self._transport = _SocketTransport()
        self._wake_r, self._wake_w = os.pipe()
        os.set_blocking(self._wake_r, False)
        os.set_blocking(self._wake_w, False)
        self._thread = threading.Thread(target=self._serve, name=f"gauge {self.name}", daemon=True)
        self._thread.start()
        log.debug("%s serving %s on %s", self.name, self.protocol, self.port)
        return self

    def close(self) -> None:
        """Stop serving and release the pty or socket (idempotent)."""
        self._stop.set()
        self._wake()
        if self._thread is not None and self._thread is not threading.current_thread():
            self._thread.join(timeout=2.0)
            if self._thread.is_alive():
                log.warning("%s: serving thread did not stop within 2 s", self.name)
        if self._transport is not None:
            self._transport.close()
        for fd in (self._wake_r, self._wake_w):
            if fd >= 0:
                with contextlib.suppress(OSError):
                    os.close(fd)
        self._wake_r = self._wake_w = -1

    def __repr__(self) -> str:
        where = self._transport.port if self._transport else "not started"
        return f"GaugeEndpoint({self.protocol!r}, {where})"

    # -------------------------------------------------------------------- faults
    def set_fault(self, kind: Fault | str, *, code: str = "", count: int | None = None,
                  pause_s: float = 0.05) -> None:
        """Switch a fault on (see :class:`Fault`).

        ``count`` limits a per-reply fault to the next ``count`` replies (None:
        until :meth:`clear_fault`); for ``stale`` it is how many old frames of the
        last value served to queue (default 3). Raises ValueError for a fault the
        protocol cannot show."""
        kind = Fault(kind)
        if kind is Fault.STALE:
            self._call(lambda: self._queue_stale(count or 3), wait=True)
            return
        if kind is Fault.UNPLUG and count is None:
            count = 1
        if kind is Fault.BUSY:
            if self.device.BUSY_CODE is None:
                raise ValueError(f"{self.protocol} has no busy reply")
            code = self.device.BUSY_CODE
        if kind is Fault.ERROR:
            if self.device.DEFAULT_ERROR is None:
                raise ValueError(f"{self.protocol} frames have no error code")
            code = code or self.device.DEFAULT_ERROR
            self.device.error_frame(code, self.default_channel)  # validate now, not mid-serve
        if kind is Fault.INCH:
            code = code or "1"
            if code not in ("1", "8"):
                raise ValueError(f"inch unit nibble is 1 or 8, got {code!r}")
        with self._lock:
            self._faults[kind] = _FaultState(code=code, remaining=count, pause_s=pause_s)

    def trigger(self) -> None:
        """Push one frame per channel now (U-WAVE data button; any free-running source)."""
        self._call(self._push_all, wait=False)

    def unplug(self) -> None:
        """Disappear now: close the pty master or drop the connection and stop listening."""
        self._call(self._unplug_now, wait=True)

    # ------------------------------------------------------------- serving loop
    def _wake(self) -> None:
        if self._wake_w >= 0:
            with contextlib.suppress(OSError):
                os.write(self._wake_w, b"!")

    def _call(self, action: Callable[[], None], *, wait: bool) -> None:
        """Run ``action`` in the serving thread, so bytes never interleave."""
        thread = self._thread
        if thread is None or not thread.is_alive():
            action()
            return
        done = threading.Event()
        self._commands.put((action, done))
        self._wake()
        if wait and not done.wait(timeout=5.0):
            log.warning("%s: serving thread did not run a command within 5 s", self.name)

    def _serve(self) -> None:
        leave_interrupts_to_the_main_thread()
        transport = self._transport
        assert transport is not None
        next_tick = time.monotonic() + self.period_s if self.period_s else math.inf
        try:
            while not self._stop.is_set() and not self.unplugged:
                timeout = min(0.5, max(0.0, next_tick - time.monotonic()))
                fds = [self._wake_r, *transport.input_fds()]
                try:
                    ready, _, _ = select.select(fds, [], [], timeout)
                except (OSError, ValueError):
                    if self._stop.is_set():
                        break
                    raise
                if self._wake_r in ready:
                    with contextlib.suppress(OSError):
                        os.read(self._wake_r, 4096)
                self._run_commands()
                for fd in ready:
                    if fd != self._wake_r and not self.unplugged:
                        data = transport.on_readable(fd)
                        if data:
                            self._on_input(data)
                if self.period_s and time.monotonic() >= next_tick and not self.unplugged:
                    self._push_all()
                    next_tick = max(next_tick + self.period_s, time.monotonic())
        except Exception:
            log.exception("%s: serving thread failed", self.name)
        finally:
            self._run_commands()  # release anyone waiting on a command

    def _run_commands(self) -> None:
        while True:
            try:
                action, done = self._commands.get_nowait()
            except queue.Empty:
                return
            try:
                if not self.unplugged:
                    action()
            finally:
                done.set()

    def _on_input(self, data: bytes) -> None:
        # The bytes took their line time to arrive: the device can only act
        # once the last one is in.
        arrival = time.monotonic()
        self._rx_free_at = max(arrival, self._rx_free_at) + len(data) * self.byte_time_s
        sleep_until(self._rx_free_at)
        self.device.on_input(data)

    # ------------------------------------------------- what the device asks for
    def count_request(self) -> None:
        """One more request received (tests count the exchanges)."""
        self.requests_received += 1

    @property
    def silent(self) -> bool:
        """Told to stay silent (``Fault.SILENCE``): no answer to anything."""
        return Fault.SILENCE in self._faults

    def emit(self, channel: str) -> None:
        """Send ``channel``'s value frame now, or what the faults make of it."""
        faults = self._take_faults()
        if Fault.UNPLUG in faults:
            whole = self._value_frame(channel, faults) or b"\r"
            self.send(whole[: max(1, len(whole) // 2)])
            self._unplug_now()
            return
        if Fault.SILENCE in faults:
            return
        error = faults.get(Fault.BUSY) or faults.get(Fault.ERROR)  # one of them at most
        frame = (self._value_frame(channel, faults) if error is None
                 else self.device.error_frame(error.code, channel))
        if frame is None:
            return
        if Fault.GARBLED in faults:
            frame = _garble(frame)
        if Fault.SPLIT in faults:
            half = len(frame) // 2
            self.send(frame[:half])
            if self._stop.wait(faults[Fault.SPLIT].pause_s):
                return
            self.send(frame[half:])
        else:
            self.send(frame)

    def _push_all(self) -> None:
        for channel in self.channels:
            if self.unplugged:
                return
            self.emit(channel)

    # ---------------------------------------------------------------- replying
    def _take_faults(self) -> dict[Fault, _FaultState]:
        """The per-reply faults applying to this reply; counts are consumed."""
        with self._lock:
            active = dict(self._faults)
            outcome = next((k for k in (Fault.UNPLUG, Fault.SILENCE, Fault.BUSY, Fault.ERROR)
                            if k in active), None)
            applied: dict[Fault, _FaultState] = {k: v for k, v in active.items()
                                                 if k in (Fault.GARBLED, Fault.SPLIT)}
            if outcome is not None:
                applied[outcome] = active[outcome]
            for kind, state in applied.items():
                if state.remaining is not None:
                    state.remaining -= 1
                    if state.remaining <= 0:
                        self._faults.pop(kind, None)
            if Fault.INCH in active:
                applied[Fault.INCH] = active[Fault.INCH]
            return applied

    def _value_frame(self, channel: str, faults: Mapping[Fault, _FaultState]) -> bytes | None:
        try:
            value_mm = float(self.channels[channel]())
        except Exception:
            log.exception("%s: value source for channel %r failed", self.name, channel)
            return None
        self._last_value_mm[channel] = value_mm
        inch = faults.get(Fault.INCH)
        unit: Unit = "inch" if inch is not None else self.unit
        nibble = inch.code if inch is not None else "1"
        return self._encode_value(value_mm, unit, channel, nibble)

    def _encode_value(self, value_mm: float, unit: Unit, channel: str,
                      inch_nibble: str) -> bytes | None:
        shown, decimals = shown_value(value_mm, unit, self.resolution_mm, self.device.MAX_DECIMALS)
        try:
            return self.device.value_frame(shown, decimals=decimals, unit=unit,
                                           channel=channel, inch_code=inch_nibble)
        except ValueError:
            log.warning("%s: %.6g mm is beyond what the display shows", self.name, value_mm)
            return self.device.overflow_frame()

    def _queue_stale(self, count: int) -> None:
        """Frames of an old value, all in the line at once (a bridge's buffer)."""
        channel = self.default_channel
        value_mm = self._last_value_mm.get(channel)
        if value_mm is None:
            value_mm = float(self.channels[channel]())
        frame = self._encode_value(value_mm, self.unit, channel, "1")
        if frame is not None and self._transport is not None:
            self._transport.send(frame * count)

    def _unplug_now(self) -> None:
        self.unplugged = True  # first, so nobody sees the link gone but the flag not set
        if self._transport is not None:
            self._transport.unplug()
        log.debug("%s: unplugged", self.name)

    def send(self, data: bytes) -> None:
        """Write ``data`` at the line rate: each byte when its last bit would be in.

        Scheduling against absolute times (not sleeping a fixed amount per
        byte) keeps sleep overshoot from accumulating over a frame."""
        transport = self._transport
        if transport is None:
            return
        byte_s = self.byte_time_s
        start = max(time.monotonic(), self._tx_free_at)
        sent = 0
        total = len(data)
        while sent < total:
            now = time.monotonic()
            due = min(total, int((now - start) / byte_s))
            if due > sent:
                transport.send(data[sent:due])
                sent = due
                continue
            if self._stop.is_set():
                return
            due_at = start + (sent + 1) * byte_s
            if sent + 1 == total:
                sleep_until(due_at)  # the byte the client waits for: on time
            else:
                time.sleep(due_at - now)
        self._tx_free_at = start + total * byte_s
