"""Mitutoyo USB-ITN cable (USB Input Tool Direct) in its data mode, over pyusb.

Out of the box the cable is a USB HID keyboard that types the value
(:mod:`ogacq_drivers.indicators.usb_itn_keyboard`). Its data mode is reached with
vendor control transfers; the replies come on the interrupt IN endpoint. Mitutoyo
publishes no description of these transfers that we could find (no maker
source): everything below is from the open reader pytuyo (github.com/rabryan/
pytuyo, ``pytuyo.py`` and its README), which a second public logger script for
several cables repeats transfer for transfer:

- vendor id 0x0FE7 (Mitutoyo), product id 0x4001; one configuration
  (``set_configuration(1)``), interface 0, whose first endpoint is the
  interrupt IN endpoint the replies come on. usbhid holds interface 0 in
  keyboard mode, so it is detached first;
- enter data mode: control OUT, bmRequestType 0x40 (vendor, host to device),
  bRequest 0x01, wValue 0xA5A5, wIndex 0, no data;
- the cable confirms: control IN, bmRequestType 0xC0, bRequest 0x02, wValue 0,
  wIndex 0, one byte, which is 0x01 (pytuyo README);
- a command: control OUT, bmRequestType 0x40, bRequest 0x03, wValue 0, wIndex 0,
  data = the command and CR: ``1\\r`` asks for a value, ``V\\r`` for the
  device information;
- the reply arrives on the interrupt endpoint in packets, up to CR. Its first
  character says what it is: ``0`` a value, which is a whole 01A reply
  (``01A+0000.123\\r``, decoded by :mod:`ogacq_drivers.indicators.mitutoyo_01a`),
  ``1`` the device information, ``9`` a status, the 01A error codes ``91x``
  (the second script notes ``918`` "until data is available again": busy).

The value has no unit (an 01A frame): the unit is recorded at setup and the
decimals must fit it, as for every 01A interface. The cable carries one gauge, so a
value names channel 1, always (pytuyo skips the first two characters as "always
1A"; Mitutoyo's QM-Height manual 99MAF600B, 6.2.2, USB data output: D2 channel
No. "1" (fixed)): a reply naming another channel is refused, not read.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Iterable
from dataclasses import dataclass
from decimal import Decimal
from typing import Any

from ogacq_drivers.errors import DeviceBusy, DeviceFault, DeviceTimeout, DriverError, FrameError
from ogacq_drivers.indicators.backend import Codec, Decoded, Example, FoundPort
from ogacq_drivers.indicators.base import IndicatorDriver, Reading, Unit
from ogacq_drivers.indicators.mitutoyo_01a import decode_reply, encode_reply
from ogacq_drivers.usb_link import open_usb_device, usb_errors

log = logging.getLogger(__name__)

VENDOR_ID = 0x0FE7  # Mitutoyo (pytuyo)
PRODUCT_ID = 0x4001  # USB-ITN (pytuyo)
INTERFACE = 0
VENDOR_OUT = 0x40  # bmRequestType: vendor, host to device (pytuyo)
VENDOR_IN = 0xC0  # bmRequestType: vendor, device to host (pytuyo)
REQUEST_DATA_MODE = 0x01  # with wValue DATA_MODE_KEY (pytuyo)
DATA_MODE_KEY = 0xA5A5
REQUEST_CONFIRM = 0x02  # answers one byte, 0x01 (pytuyo README)
CONFIRMED = 0x01
REQUEST_COMMAND = 0x03  # data: command + CR (pytuyo)
READ_COMMAND = b"1\r"
INFO_COMMAND = b"V\r"
MESSAGE_VALUE, MESSAGE_INFO, MESSAGE_STATUS = "0", "1", "9"  # first character (pytuyo)
CABLE_CHANNEL = "1"  # "always 1A" (pytuyo); 99MAF600B 6.2.2: D2 channel "1" (fixed)
MAX_MESSAGE_BYTES = 64  # a reply is 13 bytes; anything longer without CR is garbage
POLL_MS = 20  # longest one interrupt read blocks before the deadline is re-checked


@dataclass(frozen=True, slots=True)
class Message:
    """One CR-terminated message from the interrupt endpoint."""

    kind: str  # MESSAGE_VALUE, MESSAGE_INFO or MESSAGE_STATUS
    raw: bytes


def classify(raw: bytes, *, where: str = "") -> Message:
    """What a message is, by its first character; FrameError for anything else."""
    kind = raw[:1].decode("ascii", "replace")
    if kind not in (MESSAGE_VALUE, MESSAGE_INFO, MESSAGE_STATUS) or not raw.endswith(b"\r"):
        raise FrameError("not a USB-ITN message", where=where, frame=raw)
    return Message(kind, raw)


def decode(frame: bytes, *, where: str = "") -> Decoded:
    """The codec's decode of one message (up to its CR): a value is an 01A reply (no
    unit field); device information is not a value."""
    message = classify(frame, where=where)
    if message.kind == MESSAGE_INFO:
        raise FrameError("device information where a value was asked", where=where, frame=frame)
    return cable_reply(frame, where=where)  # 91x raise, classified


def cable_reply(frame: bytes, *, where: str = "") -> Decoded:
    """The 01A reply of a value message, which must name the cable's one channel."""
    reply = decode_reply(frame, where=where)
    if reply.channel != CABLE_CHANNEL:
        raise FrameError(
            f"reply names channel {reply.channel}; a USB-ITN cable's gauge is channel "
            f"{CABLE_CHANNEL}", where=where, frame=frame)
    return reply


def encode(value: Decimal, *, decimals: int, unit: Unit = "mm", channel: str = "") -> bytes:
    """The codec's encode: the 01A reply the cable sends for a value."""
    return encode_reply(value, decimals=decimals, channel=channel or "1")


CODEC = Codec(decode, encode, examples=(
    Example(b"01A+0000.123\r", "pytuyo: a value message is a whole 01A reply (this one "
            "from INSTRUMENTS.md)", value_mm=0.123),
    Example(b"918\r", "pytuyo: 9 starts a status; a second logger script: 918 until data "
            "is available again", error=DeviceBusy),
    Example(b"911\r", "pytuyo: 9 starts a status; 911 no data, as on the 01A interfaces "
            "(INSTRUMENTS.md)", error=DeviceFault),
), fixed_width=True)


def find_cables() -> list[FoundPort]:
    """The USB-ITN cables on the USB bus (needs pyusb and libusb; raises without them)."""
    import usb.core

    return [FoundPort(f"usb:{dev.bus}.{dev.address}", "Mitutoyo USB-ITN cable, data mode")
            for dev in usb.core.find(find_all=True, idVendor=VENDOR_ID, idProduct=PRODUCT_ID)]


class UsbItn(IndicatorDriver):
    """A gauge on a USB-ITN cable, in data mode (an :class:`Indicator`)."""

    def __init__(self, device: Any, *, where: str, unit: str,
                 decimals: int | Iterable[int] | None = None, channel: str = "",
                 timeout_s: float | None = None, busy_retry_delay_s: float = 0.05) -> None:
        super().__init__(where=where, timeout_s=timeout_s)
        self.device = device
        self._set_unit(unit, decimals)
        self.channel = channel
        self.busy_retry_delay_s = busy_retry_delay_s
        self._buffer = bytearray()
        self._endpoint: Any = None
        self._detached = False  # whether we took interface 0 from the kernel's usbhid
        self._enter_data_mode()

    @classmethod
    def open(cls, port: str, *, where: str, unit: str, **options: Any) -> UsbItn:
        """Find the cable ``port`` names (``usb``, ``usb:SERIAL``, ``usbsim://...``)."""
        device = open_usb_device(port, VENDOR_ID, PRODUCT_ID, where=where)
        return cls(device, where=where, unit=unit, **options)

    def _enter_data_mode(self) -> None:
        dev = self.device
        with usb_errors(self.where, "switching the USB-ITN to data mode"):
            if dev.is_kernel_driver_active(INTERFACE):
                dev.detach_kernel_driver(INTERFACE)  # usbhid holds it in keyboard mode
                self._detached = True
            dev.set_configuration(1)
            interface = dev.get_active_configuration()[(INTERFACE, 0)]
            self._endpoint = interface[0]
            dev.ctrl_transfer(VENDOR_OUT, REQUEST_DATA_MODE, DATA_MODE_KEY, 0)
            answer = bytes(dev.ctrl_transfer(VENDOR_IN, REQUEST_CONFIRM, 0, 0, 1))
        if answer != bytes([CONFIRMED]):
            raise DriverError(f"the USB-ITN did not confirm data mode (answered {answer!r}, "
                              f"expected {bytes([CONFIRMED])!r}); unplug and replug the cable",
                              where=self.where)

    # ------------------------------------------------------------ the contract
    def read(self, timeout_s: float | None = None) -> Reading:
        """Ask for a value and decode it; ``918`` (busy) is asked again until the deadline."""
        deadline = self._deadline(timeout_s)
        busy: DeviceBusy | None = None
        while True:
            try:
                return self._exchange(deadline)
            except DeviceBusy as exc:
                if time.monotonic() + self.busy_retry_delay_s >= deadline:
                    raise
                busy = exc
                time.sleep(self.busy_retry_delay_s)
            except DeviceTimeout:
                # the deadline passed while asking again: the gauge was busy, not silent
                if busy is not None:
                    raise busy from None
                raise

    def device_info(self, timeout_s: float | None = None) -> str:
        """The cable's identification (``V``), without the leading ``1``."""
        message = self._command(INFO_COMMAND, self._deadline(timeout_s))
        if message.kind == MESSAGE_STATUS:
            decode_reply(message.raw, where=self.where)  # raises the classified error
        if message.kind != MESSAGE_INFO:
            raise FrameError("not device information", where=self.where, frame=message.raw)
        return message.raw[1:-1].decode("ascii", "replace").strip()

    def flush_input(self) -> None:
        """Drop replies still queued in the cable (a reply nobody waited for)."""
        self._buffer.clear()
        while self._packet(timeout_ms=1):
            pass
        self._buffer.clear()

    def close(self) -> None:
        """Release the cable and give it back to the kernel (usbhid), as found."""
        import usb.util

        try:
            usb.util.dispose_resources(self.device)
            if self._detached:
                self.device.attach_kernel_driver(INTERFACE)
                self._detached = False
        except Exception as exc:  # closing a vanished device must not hide the first error
            log.debug("%s: releasing the USB device: %s", self.where, exc)

    # ---------------------------------------------------------------- the wire
    def _exchange(self, deadline: float) -> Reading:
        message = self._command(READ_COMMAND, deadline)
        if message.kind == MESSAGE_INFO:
            raise FrameError("device information where a value was asked", where=self.where,
                             frame=message.raw)
        reply = cable_reply(message.raw, where=self.where)  # 91x raise, classified
        return self._checked(reply.value, reply.decimals, message.raw, self.channel)

    def _command(self, command: bytes, deadline: float) -> Message:
        self.flush_input()
        with usb_errors(self.where, "sending a request"):
            self.device.ctrl_transfer(VENDOR_OUT, REQUEST_COMMAND, 0, 0, command)
        return self._message(deadline)

    def _message(self, deadline: float) -> Message:
        while b"\r" not in self._buffer:
            if len(self._buffer) > MAX_MESSAGE_BYTES:
                junk = bytes(self._buffer)
                self._buffer.clear()
                raise FrameError(f"no CR within {MAX_MESSAGE_BYTES} bytes", where=self.where,
                                 frame=junk)
            remaining_ms = int((deadline - time.monotonic()) * 1000)
            if remaining_ms <= 0:
                partial = bytes(self._buffer)
                self._buffer.clear()
                detail = (f"incomplete reply at the deadline, got {partial!r}" if partial
                          else "no reply before the deadline")
                raise DeviceTimeout(detail, where=self.where)
            self._packet(timeout_ms=min(POLL_MS, remaining_ms))
        raw, _, rest = bytes(self._buffer).partition(b"\r")
        self._buffer = bytearray(rest)
        return classify(raw + b"\r", where=self.where)

    def _packet(self, timeout_ms: int) -> bool:
        """One interrupt packet into the buffer; False when none came in time."""
        import usb.core

        with usb_errors(self.where, "reading"):
            try:
                data = self._endpoint.read(self._endpoint.wMaxPacketSize, timeout_ms)
            except usb.core.USBTimeoutError:
                return False  # nothing yet: the caller checks its deadline
        self._buffer += bytes(data)
        return bool(data)
