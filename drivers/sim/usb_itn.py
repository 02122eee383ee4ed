"""A simulated Mitutoyo USB-ITN cable, served to pyusb over TCP (``usbsim://``).

The device model answers the transfers the driver makes (pytuyo's, see
:mod:`ogacq_drivers.indicators.usb_itn`): the standard string descriptors, the vendor
request that enters data mode and its one-byte confirmation, the command
request, and the interrupt IN endpoint on which the reply comes back in
packets. A command sent before data mode is entered stalls (no source for what
the real cable does; a stall makes a driver that skipped the set-up fail
loudly). The interrupt packet size, 8 bytes, is an assumption (no source): the
driver reads whatever size the endpoint descriptor gives.

Faults as for the serial gauges (:class:`ogacq_drivers.sim.gauges.Fault`): silence,
error (``911``), busy (``918``), garbled, stale, inch, unplug (the connection
and the listener close: pyusb then sees LIBUSB_ERROR_NO_DEVICE, and a new
search finds no cable).
"""

from __future__ import annotations

import contextlib
import json
import math
import socket
import threading
import time
from collections import deque
from collections.abc import Callable
from decimal import Decimal
from typing import Any

from ogacq_drivers.indicators import mitutoyo_01a, usb_itn
from ogacq_drivers.indicators.base import Unit
from ogacq_drivers.sim.gauges import Fault, UsbCableGauge, _garble
from ogacq_drivers.threads import leave_interrupts_to_the_main_thread

PACKET_BYTES = 8  # wMaxPacketSize of the interrupt endpoint: an assumption (no source)
_INFO = b"1SIM-ITN USB-ITN simulated cable 1.0\r"
_STRINGS = {1: "Mitutoyo", 2: "USB-ITN (simulated)"}


class _Stall(Exception):
    def __init__(self, kind: str) -> None:
        self.kind = kind


def _descriptors(serial_index: int) -> dict[str, Any]:
    """The cable's device, configuration, interface and endpoint descriptors (USB 2.0
    §9.6, as pyusb's backend hands them over)."""
    endpoint = dict(bLength=7, bDescriptorType=5, bEndpointAddress=0x81, bmAttributes=3,
                    wMaxPacketSize=PACKET_BYTES, bInterval=10, bRefresh=0, bSynchAddress=0,
                    extra_descriptors=[])
    interface = dict(bLength=9, bDescriptorType=4, bInterfaceNumber=0, bAlternateSetting=0,
                     bNumEndpoints=1, bInterfaceClass=3, bInterfaceSubClass=1,
                     bInterfaceProtocol=1, iInterface=0,
                     extra_descriptors=[])  # a HID boot keyboard, as in keyboard mode
    config = dict(bLength=9, bDescriptorType=2, wTotalLength=34, bNumInterfaces=1,
                  bConfigurationValue=1, iConfiguration=0, bmAttributes=0x80, bMaxPower=50,
                  extra_descriptors=[])
    device = dict(bLength=18, bDescriptorType=1, bcdUSB=0x0110, bDeviceClass=0,
                  bDeviceSubClass=0, bDeviceProtocol=0, bMaxPacketSize0=8,
                  idVendor=usb_itn.VENDOR_ID, idProduct=usb_itn.PRODUCT_ID, bcdDevice=0x0100,
                  iManufacturer=1, iProduct=2, iSerialNumber=serial_index, bNumConfigurations=1,
                  address=7, bus=1, port_number=1, port_numbers=[1], speed=2)
    return {"device": device, "configurations": [
        {"descriptor": config, "interfaces": [{"descriptor": interface, "endpoints": [endpoint]}]}]}


class UsbItnEndpoint(UsbCableGauge):
    """One simulated USB-ITN cable and its gauge; clients open :attr:`port`."""

    protocol = "usb-itn"

    def __init__(self, value_source: Callable[[], float], *, resolution_mm: float = 0.001,
                 unit: Unit = "mm", serial: str = "SIM0001", name: str | None = None) -> None:
        super().__init__(value_source, resolution_mm=resolution_mm, unit=unit, name=name)
        self.serial = serial
        self.requests_received = 0
        # Vendor control transfers as received: (bmRequestType, bRequest, wValue, data).
        self.vendor_transfers: list[tuple[int, int, int, bytes]] = []
        self._lock = threading.Condition()
        self._packets: deque[bytes] = deque()
        self._armed = self._data_mode = False
        self._kernel_driver = True  # usbhid holds the cable: keyboard mode
        self._configuration = 0
        self._listener: socket.socket | None = None
        self._port = ""
        self._conns: list[socket.socket] = []
        self._thread: threading.Thread | None = None
        self._scripted: deque[bytes] = deque()

    def answer_next_with(self, raw: bytes) -> None:
        """The next value request is answered with ``raw`` (any bytes: garbage tests)."""
        with self._lock:
            self._scripted.append(raw)

    # ---------------------------------------------------------------- lifecycle
    def _started_port(self) -> str:
        return self._port

    def start(self) -> UsbItnEndpoint:
        if self._thread is not None:
            return self
        listener = socket.create_server(("127.0.0.1", 0), backlog=4)
        self._listener = listener
        self._port = f"usbsim://127.0.0.1:{listener.getsockname()[1]}"
        self._thread = threading.Thread(target=self._accept, name=self.name, daemon=True)
        self._thread.start()
        return self

    def close(self) -> None:
        self._disconnect()

    # ------------------------------------------------------------------- faults
    NAME = "sim usb-itn"
    CABLE = "a USB-ITN cable"
    SHOWS = (Fault.SILENCE, Fault.ERROR, Fault.BUSY, Fault.GARBLED, Fault.INCH)

    def _push_stale(self, value_mm: float, count: int) -> None:
        with self._lock:
            for _ in range(count):
                self._queue(self._frame(*self._shown(value_mm, self.unit)))

    def _fault_code(self, kind: Fault, code: str) -> str:
        if kind is Fault.ERROR:
            code = code or "911"
            mitutoyo_01a.encode_error(code)  # validate now
        return code

    def unplug(self) -> None:
        """The cable is pulled out: connections drop, and nobody can find it again."""
        self.unplugged = True
        self._disconnect()

    # ----------------------------------------------------------------- serving
    def _disconnect(self) -> None:
        with self._lock:
            conns, self._conns = self._conns, []
            self._lock.notify_all()
        for sock in [*conns, self._listener]:
            if sock is not None:
                with contextlib.suppress(OSError):
                    sock.shutdown(socket.SHUT_RDWR)
                with contextlib.suppress(OSError):
                    sock.close()

    def _accept(self) -> None:
        leave_interrupts_to_the_main_thread()
        assert self._listener is not None
        while True:
            try:
                conn, _ = self._listener.accept()
            except OSError:
                return
            conn.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
            with self._lock:
                self._conns.append(conn)
            threading.Thread(target=self._serve, args=(conn,), daemon=True,
                             name=f"{self.name} client").start()

    def _serve(self, conn: socket.socket) -> None:
        with contextlib.suppress(OSError), conn.makefile("rwb") as stream:
            for line in stream:
                request = json.loads(line)
                try:
                    answer: dict[str, Any] = {"result": self._handle(request)}
                except _Stall as stall:
                    answer = {"error": stall.kind}
                if self.unplugged:
                    return
                stream.write(json.dumps(answer).encode() + b"\n")
                stream.flush()

    def _handle(self, request: dict[str, Any]) -> Any:
        op = request.pop("op")
        if op == "descriptors":
            return _descriptors(3)
        if op in ("open", "claim_interface", "release_interface", "reset"):
            return None
        if op == "set_configuration":
            self._configuration = int(request["value"])
            return None
        if op == "get_configuration":
            return self._configuration
        if op == "kernel_driver_active":
            return self._kernel_driver
        if op in ("detach_kernel_driver", "attach_kernel_driver"):
            # The host's usbhid lets go of the cable, or takes it back (keyboard mode).
            self._kernel_driver = op == "attach_kernel_driver"
            if self._kernel_driver:
                self._armed = self._data_mode = False  # back to keyboard mode (no source)
            return None
        if op == "ctrl":
            return self._control(request)
        if op == "intr_read":
            return self._interrupt_read(int(request["size"]), int(request["timeout_ms"]))
        raise _Stall("pipe")

    def _control(self, r: dict[str, Any]) -> Any:
        kind, request, value = r["bmRequestType"], r["bRequest"], r["wValue"]
        data = bytes.fromhex(r["data"]) if r["data"] is not None else b""
        if kind == 0x80 and request == 6 and value >> 8 == 3:  # GET_DESCRIPTOR (string)
            return self._string(value & 0xFF)[: r["length"]].hex()
        if kind & 0x60 == 0x40:  # vendor requests: kept so tests can check the exchange
            self.vendor_transfers.append((kind, request, value, data))
        if kind == usb_itn.VENDOR_OUT and request == usb_itn.REQUEST_DATA_MODE:
            self._armed = value == usb_itn.DATA_MODE_KEY
            return 0
        if kind == usb_itn.VENDOR_IN and request == usb_itn.REQUEST_CONFIRM:
            self._data_mode = self._armed
            return bytes([usb_itn.CONFIRMED if self._data_mode else 0]).hex()
        if kind == usb_itn.VENDOR_OUT and request == usb_itn.REQUEST_COMMAND:
            if not self._data_mode:
                raise _Stall("pipe")
            self._command(data)
            return len(data)
        raise _Stall("pipe")

    def _string(self, index: int) -> bytes:
        if index == 0:
            return bytes([4, 3, 0x09, 0x04])  # LANGID US English
        text = self.serial if index == 3 else _STRINGS.get(index)
        if text is None:
            raise _Stall("pipe")
        encoded = text.encode("utf-16-le")
        return bytes([2 + len(encoded), 3]) + encoded

    def _command(self, command: bytes) -> None:
        self.requests_received += 1
        if command == usb_itn.INFO_COMMAND:
            with self._lock:
                self._queue(_INFO)
            return
        if command != usb_itn.READ_COMMAND:
            return
        with self._lock:
            if self._scripted:
                self._queue(self._scripted.popleft())
                return
        faults = self._take_faults()
        if Fault.SILENCE in faults:
            return
        if Fault.BUSY in faults:
            frame = mitutoyo_01a.encode_error(mitutoyo_01a.BUSY_CODE)
        elif Fault.ERROR in faults:
            frame = mitutoyo_01a.encode_error(faults[Fault.ERROR])
        else:
            frame = self._frame(*self._shown_now(faults))
        if Fault.GARBLED in faults:
            frame = _garble(frame)
        with self._lock:
            self._queue(frame)

    @staticmethod
    def _frame(shown: Decimal, decimals: int) -> bytes:
        return mitutoyo_01a.encode_reply(shown, decimals=decimals)

    def _queue(self, message: bytes) -> None:
        """Split into interrupt packets (caller holds the lock)."""
        for start in range(0, len(message), PACKET_BYTES):
            self._packets.append(message[start : start + PACKET_BYTES])
        self._lock.notify_all()

    def _interrupt_read(self, size: int, timeout_ms: int) -> str:
        deadline = time.monotonic() + (timeout_ms / 1000 if timeout_ms else math.inf)
        with self._lock:
            while not self._packets:
                remaining = deadline - time.monotonic()
                if remaining <= 0 or self.unplugged:
                    raise _Stall("timeout")
                self._lock.wait(remaining)
            packet = self._packets.popleft()
        return packet[:size].hex()
