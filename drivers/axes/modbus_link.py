"""The one module that talks to pymodbus on the client side.

pymodbus renames its keywords between minor versions (``unit`` -> ``slave`` ->
``device_id``) and rebuilt its internals in 3.13, so every client call is kept
here, behind four verbs (read registers / coils, write registers / coil), and
everything above speaks in :mod:`ogacq_drivers.errors` exceptions.

Timing rules:

- the pymodbus client is built with ``retries=0``: a request is sent once, and
  ``timeout_s`` bounds each attempt;
- reads are idempotent, so :class:`ModbusLink` repeats them itself, at most
  ``read_retries`` times, on a missing answer; a dead device therefore
  reports within ``timeout_s × (read_retries + 1)`` plus the connection attempt;
- a read answered with exception 6 "server device busy" is asked again after
  ``timeout_s``, at most ``read_retries`` times too: the Modbus Application
  Protocol V1.1b3 §7 says the server is engaged in a long-duration command and
  "the client should retransmit the message later";
- writes are never repeated: on a real controller a write may act on an edge
  (home, start a move), so the caller reads back whether it was taken. A write
  answered "busy" was not executed (§7 again); it is reported as such, not re-sent.

Every write is logged at INFO with the device, address and values.
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Literal

from pymodbus import ModbusException
from pymodbus.client import ModbusSerialClient, ModbusTcpClient
from pymodbus.exceptions import ConnectionException, ModbusIOException
from pymodbus.pdu import ExceptionResponse, ModbusPDU

from ogacq_drivers.axes.profile import Profile
from ogacq_drivers.errors import (
    DeviceBusy,
    DeviceFault,
    DeviceTimeout,
    DriverError,
    FrameError,
    LinkError,
)

log = logging.getLogger(__name__)
# pymodbus logs failed transactions itself; with no logging configured, Python's
# last-resort handler would print them. The errors raised here carry the same facts.
logging.getLogger("pymodbus").addHandler(logging.NullHandler())

#: Modbus exception codes, for messages.
EXCEPTION_NAMES = {
    1: "illegal function",
    2: "illegal data address",
    3: "illegal data value",
    4: "device failure",
    5: "acknowledge (still processing)",
    6: "device busy",
    8: "memory parity error",
    10: "gateway path unavailable",
    11: "gateway target did not respond",
}


def _bare(exc: DriverError) -> str:
    """An error's message without the ``where`` prefix it was given."""
    return str(exc).removeprefix(f"{exc.where}: ")


@dataclass(frozen=True)
class LinkStats:
    """Transactions made so far (reads and writes, attempts counted once each)."""

    reads: int
    writes: int
    read_retries: int
    #: Transactions that ended in an error (timeout, exception reply, lost link).
    failures: int = 0
    #: Of those, the ones where the device was not heard at all (a lost or refused
    #: connection, no answer after every attempt): it may have been switched off.
    losses: int = 0


class ModbusLink:
    """A Modbus TCP or RTU client with bounded timeouts and errors that name the device."""

    def __init__(self, *, transport: Literal["tcp", "rtu"], host: str = "127.0.0.1",
                 port: int = 502, serial_port: str = "", baudrate: int = 38400, bytesize: int = 8,
                 parity: str = "N", stopbits: int = 1, timeout_s: float = 0.2,
                 read_retries: int = 1) -> None:
        if transport not in ("tcp", "rtu"):
            raise ValueError(f"Modbus link: transport must be 'tcp' or 'rtu', got {transport!r}")
        if not timeout_s > 0:
            raise ValueError(f"Modbus link: timeout_s must be positive, got {timeout_s}")
        if read_retries < 0:
            raise ValueError(f"Modbus link: read_retries must be >= 0, got {read_retries}")
        if transport == "rtu" and not serial_port:
            raise ValueError("Modbus link: an RTU link needs serial_port")
        self.transport = transport
        self.timeout_s = timeout_s
        self.read_retries = read_retries
        self._client: ModbusTcpClient | ModbusSerialClient
        if transport == "tcp":
            self.endpoint = f"modbus tcp {host}:{port}"
            self._client = ModbusTcpClient(host, port=port, timeout=timeout_s, retries=0)
        else:
            self.endpoint = f"modbus rtu {serial_port} @{baudrate}"
            self._client = ModbusSerialClient(serial_port, baudrate=baudrate, bytesize=bytesize,
                                              parity=parity, stopbits=stopbits,
                                              timeout=timeout_s, retries=0)
        self._lock = threading.Lock()
        self._reads = self._writes = self._retries = self._failures = self._losses = 0

    @classmethod
    def for_profile(cls, profile: Profile, *, transport: Literal["tcp", "rtu"] | None = None,
                    host: str = "127.0.0.1", port: int | None = None, serial_port: str = "",
                    baudrate: int | None = None, timeout_s: float | None = None) -> ModbusLink:
        """A link with the profile's transport defaults; arguments given override them."""
        t = profile.transport
        return cls(transport=transport or t.default, host=host,
                   port=t.tcp_port if port is None else port, serial_port=serial_port,
                   baudrate=baudrate or t.baudrate, bytesize=t.bytesize, parity=t.parity,
                   stopbits=t.stopbits, timeout_s=timeout_s or t.timeout_s,
                   read_retries=t.read_retries)

    # ------------------------------------------------------------ life cycle

    def connect(self) -> ModbusLink:
        """Open the connection or port now (requests also connect on demand)."""
        with self._lock:
            if not self._client.connect():
                raise LinkError("cannot connect (refused, unreachable or port busy)",
                                where=self.endpoint)
        log.info("%s: connected", self.endpoint)
        return self

    def close(self) -> None:
        with self._lock:
            self._client.close()

    @property
    def connected(self) -> bool:
        """False once the connection was lost (closed on a reset or refused request)
        or never made; requests connect again on demand."""
        return bool(self._client.connected)

    def __enter__(self) -> ModbusLink:
        return self.connect()

    def __exit__(self, *exc: object) -> None:
        self.close()

    @property
    def stats(self) -> LinkStats:
        return LinkStats(self._reads, self._writes, self._retries, self._failures, self._losses)

    def check_device_id(self, device_id: int) -> None:
        """Refuse a unit id the transport cannot address.

        RTU: 1..247 (0 is broadcast, never answered; 248..255 reserved): Modbus over
        Serial Line V1.02 §2.2. TCP: 0..255; a device reached directly (not through a
        gateway) is often addressed as 255 (Modbus Messaging on TCP/IP Implementation
        Guide V1.0b, unit identifier; MR-JE-C's examples use 255)."""
        low, high = (1, 247) if self.transport == "rtu" else (0, 255)
        if not low <= device_id <= high:
            raise ValueError(f"{self.endpoint}: device id {device_id} is outside {low}..{high} "
                             f"for Modbus {self.transport.upper()}")

    def where(self, device_id: int) -> str:
        return f"{self.endpoint} device {device_id}"

    # ------------------------------------------------------------ reads

    def read_registers(self, device_id: int, address: int, count: int) -> list[int]:
        """FC3 read of ``count`` holding registers."""
        what = f"read {count} holding register(s) at {address:#06x}"
        response = self._read(device_id, what, lambda: self._client.read_holding_registers(
            address, count=count, device_id=device_id))
        registers = list(getattr(response, "registers", []))
        if len(registers) != count:
            raise FrameError(f"{what}: got {len(registers)}", where=self.where(device_id))
        return registers

    def read_coils(self, device_id: int, address: int, count: int) -> list[bool]:
        """FC1 read of ``count`` coils (they come packed in bytes: padded to eight)."""
        what = f"read {count} coil(s) at {address:#06x}"
        response = self._read(device_id, what, lambda: self._client.read_coils(
            address, count=count, device_id=device_id))
        bits = list(getattr(response, "bits", []))
        if len(bits) < count:
            raise FrameError(f"{what}: got {len(bits)}", where=self.where(device_id))
        return bits[:count]

    def read_identification(self, device_id: int) -> dict[int, str] | None:
        """FC43 / MEI 14 Read Device Identification, basic stream (read code 1) from
        object 0: object id -> text (0x00 VendorName, 0x01 ProductCode, 0x02
        MajorMinorRevision; Modbus Application Protocol V1.1b3 §6.21). None where the
        device does not answer it: exception 1 (function not implemented), 2 (no such
        object) or 3 (read code refused), §6.21's exception table, or silence (a drive
        that ignores functions it lacks). The objects are optional, so asked once,
        never an error and not counted against the link's health."""
        what = "read device identification (FC43/14)"
        try:
            response = self._execute_once(
                device_id, what,
                lambda: self._client.read_device_information(read_code=1, object_id=0,
                                                             device_id=device_id))
        except DeviceFault as exc:
            if exc.code in (1, 2, 3):
                return None
            raise
        except (DeviceTimeout, FrameError):
            return None
        objects = getattr(response, "information", {}) or {}
        # §6.21: the basic objects are ASCII strings
        return {int(k): (v if isinstance(v, bytes) else bytes(v)).decode("ascii", "replace")
                for k, v in objects.items() if not isinstance(v, list)}

    def _read(self, device_id: int, what: str, call: Callable[[], ModbusPDU]) -> ModbusPDU:
        attempts = self.read_retries + 1
        started = time.monotonic()
        for attempt in range(1, attempts + 1):
            self._reads += 1
            try:
                return self._execute(device_id, what, call)
            except DeviceBusy as exc:
                if attempt == attempts:
                    raise DeviceBusy(f"{_bare(exc)}, still after {attempts} attempt(s) "
                                     f"{self.timeout_s:g} s apart", code=6,
                                     where=exc.where) from None
                self._retries += 1
                log.warning("%s: %s: device busy (exception 6), asking again in %g s (%d/%d)",
                            self.where(device_id), what, self.timeout_s, attempt, attempts - 1)
                time.sleep(self.timeout_s)
            except DeviceTimeout:
                if attempt == attempts:
                    self._losses += 1
                    took_s = time.monotonic() - started
                    raise DeviceTimeout(f"{what}: no answer after {attempts} attempt(s) of "
                                        f"{self.timeout_s:g} s ({took_s:.2f} s)",
                                        where=self.where(device_id)) from None
                self._retries += 1
                log.warning("%s: %s: no answer, retrying (%d/%d)", self.where(device_id), what,
                            attempt, attempts - 1)
        raise AssertionError("unreachable")

    # ------------------------------------------------------------ writes (never retried)

    def write_register(self, device_id: int, address: int, value: int, *, what: str) -> None:
        """FC6 write of one register, sent once."""
        self._write(device_id, what, f"register {address:#06x} <- {value:#06x}",
                    f"({address:#06x})",
                    lambda: self._client.write_register(address, value, device_id=device_id))

    def write_registers(self, device_id: int, address: int, values: Sequence[int], *,
                        what: str) -> None:
        """FC16 write of consecutive registers, sent once."""
        shown = " ".join(f"{v:#06x}" for v in values)
        self._write(device_id, what, f"registers {address:#06x}.. <- [{shown}]",
                    f"({len(values)} registers at {address:#06x})",
                    lambda: self._client.write_registers(address, list(values),
                                                         device_id=device_id))

    def write_coil(self, device_id: int, address: int, value: bool, *, what: str) -> None:
        """FC5 write of one coil, sent once."""
        self._write(device_id, what, f"coil {address:#06x} <- {'ON' if value else 'OFF'}",
                    f"(coil {address:#06x})",
                    lambda: self._client.write_coil(address, value, device_id=device_id))

    def _write(self, device_id: int, what: str, written: str, target: str,
               call: Callable[[], ModbusPDU]) -> None:
        """Log ``written`` (the audit of every write), then send the request once;
        errors say ``write {what} {target}``."""
        log.info("%s: write %s: %s", self.where(device_id), what, written)
        what = f"write {what} {target}"
        self._writes += 1
        try:
            self._execute(device_id, what, call)
        except DeviceBusy as exc:
            raise DeviceBusy(f"{_bare(exc)}: the device did not execute it; not re-sent",
                             code=6, where=exc.where) from None
        except DeviceTimeout as exc:
            self._losses += 1
            # The write may or may not have been executed: say so, the caller reads back.
            raise DeviceTimeout(f"{what}: no answer within {self.timeout_s:g} s; not re-sent, "
                                "the device may or may not have taken it",
                                where=exc.where) from None

    # ------------------------------------------------------------ error mapping

    def _execute(self, device_id: int, what: str, call: Callable[[], ModbusPDU]) -> ModbusPDU:
        try:
            return self._execute_once(device_id, what, call)
        except LinkError:
            self._failures += 1
            self._losses += 1
            raise
        except DriverError:
            self._failures += 1
            raise

    def _execute_once(self, device_id: int, what: str, call: Callable[[], ModbusPDU]) -> ModbusPDU:
        where = self.where(device_id)
        with self._lock:
            try:
                response = call()
            except ConnectionException as exc:
                self._client.close()
                raise LinkError(f"{what}: connection failed or lost ({exc})", where=where) from exc
            except ModbusIOException as exc:
                text = str(exc)
                if "device id" in text or "transaction id" in text:
                    raise FrameError(f"{what}: answer does not match the request ({text})",
                                     where=where) from exc
                raise DeviceTimeout(f"{what}: no answer within {self.timeout_s:g} s",
                                    where=where) from exc
            except ModbusException as exc:
                raise FrameError(f"{what}: {exc}", where=where) from exc
            except OSError as exc:
                self._client.close()
                raise LinkError(f"{what}: {exc}", where=where) from exc
        if isinstance(response, ExceptionResponse) or response.isError():
            code = int(getattr(response, "exception_code", 0))
            name = EXCEPTION_NAMES.get(code, "unknown exception")
            message = f"{what}: device answered exception {code} ({name})"
            if code == 6:
                raise DeviceBusy(message, code=code, where=where)
            if code == 11:
                raise DeviceTimeout(message, where=where)
            raise DeviceFault(message, code=code, where=where)
        return response
