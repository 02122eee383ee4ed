"""A pyusb backend for a USB device served over TCP (the simulator's ``usbsim://``).

pyusb lets a program bring its own backend (``usb.backend.IBackend``); this one
forwards each backend call (descriptors, configuration, control transfers,
interrupt reads) to a device model in another thread or process, one JSON line
per request and per answer. The driver above it is the code that talks to real
hardware through libusb: only the last hop differs.

Failures are raised as libusb's would be through pyusb's libusb1 backend
(``USBTimeoutError`` for LIBUSB_ERROR_TIMEOUT, ``USBError`` with errno ENODEV
for LIBUSB_ERROR_NO_DEVICE, EPIPE for a stall), so the driver's error handling
is exercised as on hardware.
"""

from __future__ import annotations

import contextlib
import errno
import json
import socket
import threading
from array import array
from collections.abc import Iterator
from types import SimpleNamespace
from typing import Any

import usb.backend
import usb.core

# libusb error codes (libusb.h) and the errno pyusb's libusb1 backend pairs with them.
_ERRORS = {
    "timeout": (usb.core.USBTimeoutError, "Operation timed out", -7, errno.ETIMEDOUT),
    "no_device": (usb.core.USBError, "No such device (it may have been disconnected)", -4,
                  errno.ENODEV),
    "pipe": (usb.core.USBError, "Pipe error", -9, errno.EPIPE),
}


def usb_error(kind: str) -> usb.core.USBError:
    cls, text, code, number = _ERRORS[kind]
    return cls(text, code, number)


class NetBackend(usb.backend.IBackend):
    """Backend whose one device lives at ``host:port``."""

    def __init__(self, host: str, port: int, *, where: str = "") -> None:
        self.address = (host, port)
        self.where = where
        self._sock: socket.socket | None = None
        self._file: Any = None
        self._lock = threading.Lock()
        self._tree: dict[str, Any] | None = None

    # -------------------------------------------------------------- the wire
    def _connect(self) -> None:
        sock = socket.create_connection(self.address, timeout=5)
        sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        self._sock, self._file = sock, sock.makefile("rwb")

    def _call(self, op: str, **fields: Any) -> Any:
        with self._lock:
            if self._sock is None:
                try:
                    self._connect()
                except OSError:
                    raise usb_error("no_device") from None  # nobody serves it: unplugged
            try:
                self._file.write(json.dumps({"op": op, **fields}).encode() + b"\n")
                self._file.flush()
                line = self._file.readline()
            except OSError:
                line = b""
            if not line:
                self._drop()
                raise usb_error("no_device")
        answer = json.loads(line)
        if "error" in answer:
            raise usb_error(answer["error"])
        return answer.get("result")

    def _drop(self) -> None:
        for thing in (self._file, self._sock):
            if thing is not None:
                with contextlib.suppress(OSError):
                    thing.close()
        self._sock = self._file = None

    # ----------------------------------------------------------- descriptors
    def enumerate_devices(self) -> Iterator[str]:
        try:
            self._tree = self._call("descriptors")
        except usb.core.USBError:
            return  # nothing served there: an empty bus, as with the cable unplugged
        yield "device"

    def _descriptors(self) -> dict[str, Any]:
        if self._tree is None:
            self._tree = self._call("descriptors")
        return self._tree

    def get_device_descriptor(self, dev: Any) -> SimpleNamespace:
        return SimpleNamespace(**self._descriptors()["device"])

    def get_configuration_descriptor(self, dev: Any, config: int) -> SimpleNamespace:
        entry = self._descriptors()["configurations"][config]
        return SimpleNamespace(**entry["descriptor"])

    def get_interface_descriptor(self, dev: Any, intf: int, alt: int, config: int,
                                 ) -> SimpleNamespace:
        entry = self._descriptors()["configurations"][config]["interfaces"][intf]
        return SimpleNamespace(**entry["descriptor"])

    def get_endpoint_descriptor(self, dev: Any, ep: int, intf: int, alt: int, config: int,
                                ) -> SimpleNamespace:
        entry = self._descriptors()["configurations"][config]["interfaces"][intf]
        return SimpleNamespace(**entry["endpoints"][ep])

    # ------------------------------------------------------------- operations
    def open_device(self, dev: Any) -> str:
        self._call("open")
        return "handle"

    def close_device(self, dev_handle: Any) -> None:
        self._drop()

    def set_configuration(self, dev_handle: Any, config_value: int) -> None:
        self._call("set_configuration", value=config_value)

    def get_configuration(self, dev_handle: Any) -> int:
        return int(self._call("get_configuration"))

    def claim_interface(self, dev_handle: Any, intf: int) -> None:
        self._call("claim_interface", interface=intf)

    def release_interface(self, dev_handle: Any, intf: int) -> None:
        with contextlib.suppress(usb.core.USBError):  # a vanished device: nothing to release
            self._call("release_interface", interface=intf)

    def ctrl_transfer(self, dev_handle: Any, bmRequestType: int, bRequest: int,  # noqa: N803
                      wValue: int, wIndex: int, data: array[int], timeout: int) -> int:
        outgoing = not bmRequestType & 0x80
        result = self._call("ctrl", bmRequestType=bmRequestType, bRequest=bRequest, wValue=wValue,
                            wIndex=wIndex, data=bytes(data).hex() if outgoing else None,
                            length=len(data), timeout_ms=timeout)
        if outgoing:
            return int(result)
        received = bytes.fromhex(result)
        data[: len(received)] = type(data)(data.typecode, received)
        return len(received)

    def intr_read(self, dev_handle: Any, ep: int, intf: int, buff: array[int], timeout: int,
                  ) -> int:
        received = bytes.fromhex(self._call("intr_read", endpoint=ep, size=len(buff),
                                            timeout_ms=timeout))
        buff[: len(received)] = type(buff)(buff.typecode, received)
        return len(received)

    def is_kernel_driver_active(self, dev_handle: Any, intf: int) -> bool:
        return bool(self._call("kernel_driver_active", interface=intf))

    def detach_kernel_driver(self, dev_handle: Any, intf: int) -> None:
        self._call("detach_kernel_driver", interface=intf)

    def attach_kernel_driver(self, dev_handle: Any, intf: int) -> None:
        self._call("attach_kernel_driver", interface=intf)

    def reset_device(self, dev_handle: Any) -> None:
        self._call("reset")
