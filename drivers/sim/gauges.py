"""Simulated gauges that speak the exact indicator wire formats.

A :class:`GaugeEndpoint` serves one serial protocol (``"mitutoyo-01a"``,
``"digimatic"``, ``"uwave"``, ``"sylvac"``, ``"sylvac-simplex"``) on a real
pseudo-terminal (clients open the slave path like a ``/dev/ttyUSB``), on a
loopback TCP socket (clients open ``socket://127.0.0.1:PORT``) or on an RFC 2217
server (``rfc2217://127.0.0.1:PORT``), the one of the three that carries the
control lines: the Sylvac simplex cable is asked for a value by a DTR pulse, so
it is always served that way (pyserial's own RFC 2217 port manager decodes the
client's SET_CONTROL requests here). Values come from
``value_source`` callables (the simulated machine, or a lambda in tests), are
rounded to the display resolution and encoded with the drivers' own encoders,
so every end-to-end test runs the real codecs.

Output is paced at the configured baud rate (10 or 11 bits per byte), and so
is input, because neither a pty nor a socket enforces a rate: a request/reply
exchange takes as long as on the real line.

Faults are switched at run time with :meth:`GaugeEndpoint.set_fault` (see
:class:`Fault`) so drivers can be shown to report each one clearly.
"""

from __future__ import annotations

import contextlib
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
from typing import Any, Literal

from ogacq_drivers.indicators import BACKENDS, digimatic, mitutoyo_01a, sylvac, uwave
from ogacq_drivers.indicators.base import Unit
from ogacq_drivers.link import LinkSettings
from ogacq_drivers.sim.clock import sleep_until

log = logging.getLogger(__name__)

ValueSource = Callable[[], float]
Transport = Literal["pty", "socket", "rfc2217"]
PROTOCOLS = tuple(BACKENDS)
MM_PER_INCH = 25.4

_DEFAULT_CHANNEL = {
    "mitutoyo-01a": "1",
    "digimatic": "",
    "uwave": "0000",
    "sylvac": "",
    "sylvac-simplex": "",
}
_MAX_DECIMALS = {"mitutoyo-01a": 6, "digimatic": 5, "uwave": 9, "sylvac": 7, "sylvac-simplex": 7}
_DEFAULT_ERROR = {"mitutoyo-01a": "911", "uwave": "01", "sylvac": "3", "sylvac-simplex": "3"}
_SYLVAC = ("sylvac", "sylvac-simplex")
# Shortest DTR-low pulse a simplex instrument takes as a request (Opto-RS manual: 110 ms).
_SIMPLEX_PULSE_S = 0.110
_DEVICE_INFO = b"SIM-ITN 01A simulated interface 1.0\r"


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
    inch; ``code`` "1" or "8" picks the Digimatic unit nibble).
    """

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
    """What every simulated gauge endpoint (serial, USB, keyboard) shares: used as a
    context manager around ``start``/``close``, and a table of the faults it has
    been told to show, guarded by ``_lock``."""

    _faults: dict[Fault, Any]
    _lock: Any  # a Lock or a Condition

    def start(self) -> Any:
        raise NotImplementedError

    def close(self) -> None:
        raise NotImplementedError

    def __enter__(self) -> Any:
        return self.start()

    def __exit__(self, *exc_info: object) -> None:
        self.close()

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
    unit: Unit
    value_source: Callable[[], float]
    _last_value_mm: float | None

    def unplug(self) -> None:
        raise NotImplementedError

    def _push_stale(self, value_mm: float, count: int) -> None:
        raise NotImplementedError

    def _fault_code(self, kind: Fault, code: str) -> str:
        """The code a fault is shown with, checked now (not at the next reply)."""
        return code

    def set_fault(
        self, kind: Fault | str, *, code: str = "", count: int | None = None, **_: Any
    ) -> None:
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
        listener = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        listener.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        listener.bind(("127.0.0.1", 0))
        listener.listen(1)
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

            self._manager = PortManager(_ControlLines(self._on_control), self)
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


def _garble(frame: bytes) -> bytes:
    """Replace the middle byte of the frame body with one no grammar accepts."""
    body = frame.rstrip(b"\r\n")
    index = len(body) // 2
    return body[:index] + b"#" + body[index + 1 :] + frame[len(body) :]


class GaugeEndpoint(SimulatedGauge):
    """One simulated gauge (or 01A multiplexer / U-WAVE receiver) on a pty or a socket.

    ``value_source`` gives the true value in mm (noise included); a mapping
    ``{channel: source}`` serves several channels (01A multiplexer channels
    ``"1"``..; U-WAVE transmitters ``"GGCC"``). ``resolution_mm`` is the
    display resolution in mm; ``unit`` the display unit. ``baud`` (default:
    the protocol's) paces the bytes. Digimatic answers any byte with a frame
    unless ``streaming`` (a frame every ``period_s``, default 10 ms); U-WAVE
    pushes on :meth:`trigger` and every ``period_s`` if given.
    """

    def __init__(
        self,
        protocol: str,
        value_source: ValueSource | Mapping[str, ValueSource],
        *,
        resolution_mm: float = 0.001,
        unit: Unit = "mm",
        channel: str | None = None,
        baud: int | None = None,
        transport: Transport = "pty",
        streaming: bool = False,
        period_s: float | None = None,
        name: str | None = None,
        digimatic2: bool = False,
    ) -> None:
        if protocol not in BACKENDS:
            raise ValueError(f"unknown protocol {protocol!r} (known: {', '.join(PROTOCOLS)})")
        if transport not in ("pty", "socket", "rfc2217"):
            raise ValueError(f"transport must be 'pty', 'socket' or 'rfc2217', got {transport!r}")
        if protocol == "sylvac-simplex":
            transport = "rfc2217"  # the request is a DTR pulse: only RFC 2217 carries it
        if unit not in ("mm", "inch"):
            raise ValueError(f"unit must be 'mm' or 'inch', got {unit!r}")
        if resolution_mm <= 0:
            raise ValueError(f"resolution_mm must be positive, got {resolution_mm}")
        self.protocol = protocol
        self.transport_kind: Transport = transport
        settings: LinkSettings = BACKENDS[protocol].settings
        if baud is not None:
            settings = replace(settings, baudrate=baud)
        self.settings = settings
        self.byte_time_s = settings.byte_time_s
        if callable(value_source):
            self.channels: dict[str, ValueSource] = {
                channel if channel is not None else _DEFAULT_CHANNEL[protocol]: value_source
            }
        else:
            self.channels = dict(value_source)
            if not self.channels:
                raise ValueError("value_source mapping has no channels")
        for ident in self.channels:
            self._check_channel(ident)
        self.default_channel = channel if channel is not None else next(iter(self.channels))
        self.resolution_mm = resolution_mm
        self.unit: Unit = unit
        self._mm_decimals = _decimals_for(resolution_mm, _MAX_DECIMALS[protocol])
        self._inch_decimals = _decimals_for(resolution_mm / MM_PER_INCH, _MAX_DECIMALS[protocol])
        self.streaming = streaming
        self.digimatic2 = digimatic2  # eight-digit Digimatic 2 frames (99MAF600B 6.2.1)
        if streaming and protocol != "digimatic":
            raise ValueError("only the Digimatic bridge streams")
        if period_s is None and streaming:
            period_s = 0.01
        if period_s is not None and protocol not in ("digimatic", "uwave"):
            raise ValueError(f"{protocol} answers requests; it has no output period")
        # A frame takes its line time whatever the period: a stream faster than
        # the line simply sends frames back to back.
        self.period_s = period_s
        self.name = name or f"sim-{protocol}"

        self.frames_sent = 0
        self.requests_received = 0
        self.unplugged = False
        self._faults: dict[Fault, _FaultState] = {}
        self._lock = threading.Lock()
        self._commands: queue.SimpleQueue[tuple[Callable[[], None], threading.Event]] = (
            queue.SimpleQueue()
        )
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._transport: _PtyTransport | _SocketTransport | None = None
        self._wake_r = self._wake_w = -1
        self._rx_buffer = bytearray()
        self._rx_free_at = 0.0
        self._tx_free_at = 0.0
        self._last_value_mm: dict[str, float] = {}
        self._dtr_low_since: float | None = None
        self.identification = sylvac.encode_identification("235", "1")  # sent at power-on

    # ----------------------------------------------------------------- lifecycle
    @property
    def port(self) -> str:
        """What a client opens: the pty slave path or ``socket://127.0.0.1:PORT``."""
        if self._transport is None:
            raise RuntimeError(f"{self.name}: start() the endpoint before asking for its port")
        return self._transport.port

    def start(self) -> GaugeEndpoint:
        """Create the pty or socket and start serving in a daemon thread."""
        if self._thread is not None:
            return self
        if self.transport_kind == "pty":
            self._transport = _PtyTransport()
        elif self.transport_kind == "rfc2217":
            self._transport = _Rfc2217Transport(self._on_control)
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
    def set_fault(
        self,
        kind: Fault | str,
        *,
        code: str = "",
        count: int | None = None,
        pause_s: float = 0.05,
        value_mm: float | None = None,
    ) -> None:
        """Switch a fault on (see :class:`Fault`).

        ``count`` limits a per-reply fault to the next ``count`` replies (None:
        until :meth:`clear_fault`); for ``stale`` it is how many old frames to
        queue (default 3), with value ``value_mm`` (default: the last value
        served). Raises ValueError for a fault the protocol cannot show.
        """
        kind = Fault(kind)
        if kind is Fault.STALE:
            self._call(lambda: self._queue_stale(count or 3, value_mm), wait=True)
            return
        if kind is Fault.UNPLUG and count is None:
            count = 1
        if kind is Fault.BUSY:
            if self.protocol != "mitutoyo-01a":
                raise ValueError(f"{self.protocol} has no busy reply")
            code = mitutoyo_01a.BUSY_CODE
        if kind is Fault.ERROR:
            if self.protocol not in _DEFAULT_ERROR:
                raise ValueError(f"{self.protocol} frames have no error code")
            code = code or _DEFAULT_ERROR[self.protocol]
            self._error_frame(code, self.default_channel)  # validate now, not mid-serve
        if kind is Fault.INCH:
            code = code or "1"
            if code not in ("1", "8"):
                raise ValueError(f"inch unit nibble is 1 or 8, got {code!r}")
        with self._lock:
            self._faults[kind] = _FaultState(code=code, remaining=count, pause_s=pause_s)

    def trigger(self, *, wait: bool = False) -> None:
        """Push one frame per channel now (U-WAVE data button; any free-running source)."""
        self._call(self._push_all, wait=wait)

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
        if self.protocol == "digimatic":
            if not self.streaming:
                for _ in data:  # a polled bridge answers every byte
                    self.requests_received += 1
                    self._emit(self.default_channel)
            return
        if self.protocol in ("uwave", "sylvac-simplex"):
            return  # the receiver pushes; a simplex instrument ignores commands
        self._rx_buffer += data.replace(b"\n", b"")
        while b"\r" in self._rx_buffer:
            line, _, rest = bytes(self._rx_buffer).partition(b"\r")
            self._rx_buffer = bytearray(rest)
            self.requests_received += 1
            self._answer(line)
        if len(self._rx_buffer) > 64:
            self._rx_buffer.clear()

    def _answer(self, line: bytes) -> None:
        text = line.decode("ascii", "replace").strip()
        if self.protocol == "mitutoyo-01a":
            if text == "V":
                if Fault.SILENCE not in self._faults:
                    self._send_paced(_DEVICE_INFO)
            elif text in self.channels:
                self._emit(text)
            elif len(text) == 1 and text.isalnum():
                self._send_paced(mitutoyo_01a.encode_error("911"))  # nothing on that channel
            else:
                log.debug("%s: ignoring request %r", self.name, line)
        else:  # sylvac
            command = text.upper()
            if command == "?":
                self._emit(self.default_channel)
            elif command in ("MM", "IN"):
                self.unit = "mm" if command == "MM" else "inch"
            else:
                self._send_paced(sylvac.encode_error(1))

    def _on_control(self, line: str, level: bool) -> None:
        """A control line changed (RFC 2217 SET_CONTROL, in the serving thread)."""
        if self.protocol != "sylvac-simplex":
            return
        if line == "rts" and level:  # the cable powers the instrument up: it says who it is
            self._send_paced(self.identification)
        elif line == "dtr" and not level:
            self._dtr_low_since = time.monotonic()
        elif line == "dtr" and level and self._dtr_low_since is not None:
            low_s = time.monotonic() - self._dtr_low_since
            self._dtr_low_since = None
            if low_s >= _SIMPLEX_PULSE_S:
                self.requests_received += 1
                self._emit(self.default_channel)
            else:
                log.debug("%s: DTR low %.0f ms, too short for a request", self.name, low_s * 1e3)

    def _push_all(self) -> None:
        for channel in self.channels:
            if self.unplugged:
                return
            self._emit(channel)

    # ---------------------------------------------------------------- replying
    def _take_faults(self) -> dict[Fault, _FaultState]:
        """The per-reply faults applying to this reply; counts are consumed."""
        with self._lock:
            active = dict(self._faults)
            outcome = next(
                (k for k in (Fault.UNPLUG, Fault.SILENCE, Fault.BUSY, Fault.ERROR) if k in active),
                None,
            )
            applied = {k: v for k, v in active.items() if k in (Fault.GARBLED, Fault.SPLIT)}
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

    def _emit(self, channel: str) -> None:
        faults = self._take_faults()
        if Fault.UNPLUG in faults:
            frame = self._value_frame(channel, faults) or b"\r"
            self._send_paced(frame[: max(1, len(frame) // 2)])
            self._unplug_now()
            return
        if Fault.SILENCE in faults:
            return
        if Fault.BUSY in faults:
            frame: bytes | None = self._error_frame(mitutoyo_01a.BUSY_CODE, channel)
        elif Fault.ERROR in faults:
            frame = self._error_frame(faults[Fault.ERROR].code, channel)
        else:
            frame = self._value_frame(channel, faults)
        if frame is None:
            return
        if Fault.GARBLED in faults:
            frame = _garble(frame)
        if Fault.SPLIT in faults:
            half = len(frame) // 2
            self._send_paced(frame[:half])
            if self._stop.wait(faults[Fault.SPLIT].pause_s):
                return
            self._send_paced(frame[half:])
        else:
            self._send_paced(frame)
        self.frames_sent += 1

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

    def _encode_value(
        self, value_mm: float, unit: Unit, channel: str, inch_nibble: str
    ) -> bytes | None:
        if unit == "mm":
            decimals = self._mm_decimals
            steps = round(value_mm / self.resolution_mm)
            shown = Decimal(steps) * Decimal(str(self.resolution_mm))
        else:
            decimals = self._inch_decimals
            shown = Decimal(repr(value_mm / MM_PER_INCH))
        try:
            if self.protocol == "mitutoyo-01a":
                return mitutoyo_01a.encode_reply(shown, decimals=decimals, channel=channel)
            if self.protocol == "digimatic":
                return digimatic.encode_frame(
                    shown,
                    decimals=decimals,
                    unit=unit,
                    inch_nibble=inch_nibble,
                    digimatic2=self.digimatic2,
                )
            if self.protocol == "uwave":
                return uwave.encode_data(shown, decimals=decimals, unit=unit, gauge_id=channel)
            return sylvac.encode_reply(shown, decimals=decimals)  # both Sylvac cables
        except ValueError:
            log.warning("%s: %.6g mm is beyond what the display shows", self.name, value_mm)
            if self.protocol in _SYLVAC:
                return sylvac.encode_error(3)  # out of measuring range
            return None

    def _error_frame(self, code: str, channel: str) -> bytes:
        if self.protocol == "mitutoyo-01a":
            return mitutoyo_01a.encode_error(code)
        if self.protocol in _SYLVAC:
            return sylvac.encode_error(code)
        return uwave.encode_status(code, gauge_id=channel)

    def _queue_stale(self, count: int, value_mm: float | None) -> None:
        """Frames of an old value, all in the line at once (a bridge's buffer)."""
        channel = self.default_channel
        if value_mm is None:
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

    def _send_paced(self, data: bytes) -> None:
        """Write ``data`` at the line rate: each byte when its last bit would be in.

        Scheduling against absolute times (not sleeping a fixed amount per
        byte) keeps sleep overshoot from accumulating over a frame.
        """
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

    def _check_channel(self, ident: str) -> None:
        if self.protocol == "mitutoyo-01a":
            mitutoyo_01a.encode_request(ident)  # raises ValueError when not a channel id
        elif self.protocol == "uwave" and not (len(ident) == 4 and ident.isdigit()):
            raise ValueError(f"U-WAVE channel is group and channel 'GGCC', got {ident!r}")
