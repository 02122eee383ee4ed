"""Open a USB device from a port string, as :mod:`ogacq_drivers.link` does for serial ports.

Port strings (the USB counterpart of device paths and pyserial URLs):

- ``usb``: the one device with the driver's vendor and product id;
- ``usb:SERIAL``: the device whose serial-number string is ``SERIAL`` (several
  cables on one PC);
- ``usb:BUS.ADDRESS``: the device at that bus and address (``lsusb`` shows them);
- ``usbsim://HOST:PORT``: a device served over TCP by the simulator
  (:mod:`ogacq_drivers.usb_net`); everything above the backend is the same code.

pyusb is an optional dependency (``pip install 'ogacq[usb]'``): without it, or
without libusb, the error says so in one line. Every pyusb failure while
talking to the device goes through :func:`usb_errors`, which turns it into a
:class:`~ogacq_drivers.errors.LinkError` (unplugged, no permission) or a
:class:`~ogacq_drivers.errors.DeviceTimeout`.
"""

from __future__ import annotations

import errno
import logging
import re
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

from ogacq_drivers.errors import DeviceTimeout, LinkError

log = logging.getLogger(__name__)

PYUSB_MISSING = (
    "USB cables need pyusb, which is not installed: pip install 'ogacq[usb]' "
    "(and libusb-1.0, e.g. apt install libusb-1.0-0)"
)

_BUS_ADDRESS = re.compile(r"([0-9]{1,3})\.([0-9]{1,3})")


def import_usb(where: str = "") -> Any:
    """``usb.core``, or a LinkError saying how to install pyusb."""
    try:
        import usb.core
        import usb.util  # noqa: F401  (get_string, used by callers)
    except ImportError:
        raise LinkError(PYUSB_MISSING, where=where) from None
    return usb.core


@contextmanager
def usb_errors(where: str, action: str) -> Iterator[None]:
    """Turn pyusb failures into LinkError (device gone, refused) or DeviceTimeout."""
    usb_core = import_usb(where)
    try:
        yield
    except usb_core.USBTimeoutError as exc:
        raise DeviceTimeout(f"no answer while {action} ({exc})", where=where) from exc
    except usb_core.USBError as exc:
        hint = ""
        if exc.errno in (errno.ENODEV, errno.ENOENT, errno.EIO):
            hint = "; was the cable unplugged?"
        elif exc.errno == errno.EACCES:
            hint = "; permission denied: add a udev rule for the device or run as a user allowed to"
        elif exc.errno == errno.EBUSY:
            hint = "; another program holds the device"
        raise LinkError(f"USB link lost while {action} ({exc}){hint}", where=where) from exc


def _backend(port: str, where: str) -> Any:
    if not port.startswith("usbsim://"):
        return None  # pyusb picks libusb
    from ogacq_drivers.usb_net import NetBackend

    host, _, number = port.removeprefix("usbsim://").rpartition(":")
    if not number.isdigit():
        raise LinkError(f"{port}: expected usbsim://HOST:PORT", where=where)
    return NetBackend(host or "127.0.0.1", int(number), where=where)


def open_usb_device(port: str, vendor_id: int, product_id: int, *, where: str) -> Any:
    """The ``usb.core.Device`` that ``port`` names, among devices with this vendor and
    product id. LinkError naming the port when there is none, or several and the
    port does not say which."""
    usb_core = import_usb(where)
    ids = f"{vendor_id:04x}:{product_id:04x}"
    backend = _backend(port, where)
    try:
        found = list(usb_core.find(find_all=True, idVendor=vendor_id, idProduct=product_id,
                                   backend=backend))
    except usb_core.NoBackendError:
        raise LinkError("libusb is not available: install libusb-1.0 (apt install libusb-1.0-0)",
                        where=where) from None
    except (usb_core.USBError, OSError) as exc:
        raise LinkError(f"cannot list USB devices for {port}: {exc}", where=where) from exc
    wanted = port.partition(":")[2] if port.startswith("usb:") else ""
    if wanted:
        found = [d for d in found if _matches(d, wanted, where)]
    if not found:
        which = f" with {wanted!r}" if wanted else ""
        raise LinkError(f"no USB device {ids}{which} on {port}: is the cable plugged in "
                        "(lsusb lists it)?", where=where)
    if len(found) > 1:
        names = ", ".join(f"usb:{d.bus}.{d.address}" for d in found)
        raise LinkError(f"{len(found)} USB devices {ids} found ({names}): name one as the port",
                        where=where)
    log.debug("%s: USB device %s at bus %s address %s", where, ids, found[0].bus, found[0].address)
    return found[0]


def _matches(device: Any, wanted: str, where: str) -> bool:
    bus_address = _BUS_ADDRESS.fullmatch(wanted)
    if bus_address is not None:
        return (device.bus, device.address) == tuple(int(g) for g in bus_address.groups())
    if not device.iSerialNumber:
        return False
    import usb.util

    with usb_errors(where, "reading the serial number"):
        return bool(usb.util.get_string(device, device.iSerialNumber) == wanted)
