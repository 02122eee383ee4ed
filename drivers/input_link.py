"""Find and open a Linux input-event device (``/dev/input/eventN``) by vendor and product id.

A keyboard-wedge cable is a USB keyboard: the kernel gives it an event device
next to the operator's own keyboard. It is identified by the ids the kernel
publishes for every input device, ``/sys/class/input/eventN/device/id/vendor``
and ``.../product`` (hex text; Linux ``drivers/input/input.c``, the ``id``
attribute group), never by its name or its order, so a technician's keyboard is
never read by mistake. An explicit ``/dev/input/eventN`` is checked the same way.

The sysfs tree is looked up relative to the device node: ``ROOT/dev/input/eventN``
is described by ``ROOT/sys/class/input/eventN``, ROOT being ``/`` on a real
system. The simulator builds such a tree in a temporary folder, so the very same
lookup and checks run in the tests.

Events are ``struct input_event`` (``linux/input.h``): a ``struct timeval`` (two
longs), ``__u16 type``, ``__u16 code``, ``__s32 value``; native layout.
"""

from __future__ import annotations

import errno
import fcntl
import logging
import os
import struct
from pathlib import Path

from ogacq_drivers.errors import LinkError

log = logging.getLogger(__name__)

EVENT = struct.Struct("@llHHi")  # struct input_event (linux/input.h), 24 bytes on 64-bit
EVIOCGRAB = 0x40044590  # _IOW('E', 0x90, int) (linux/input.h): exclusive access


def sysfs_dir(node: Path) -> Path:
    """``ROOT/sys/class/input/eventN`` for the node ``ROOT/dev/input/eventN``."""
    return node.parents[2] / "sys" / "class" / "input" / node.name


def device_ids(node: Path) -> tuple[int, int] | None:
    """(vendor, product) the kernel reports for ``node``; None when it reports none."""
    ids = sysfs_dir(node) / "device" / "id"
    try:
        return int((ids / "vendor").read_text(), 16), int((ids / "product").read_text(), 16)
    except (OSError, ValueError):
        return None


def find_event_devices(vendor_id: int, product_id: int, root: Path = Path("/")) -> list[Path]:
    """The event device nodes whose device has these ids."""
    found = []
    for entry in sorted((root / "sys" / "class" / "input").glob("event*")):
        node = root / "dev" / "input" / entry.name
        if device_ids(node) == (vendor_id, product_id):
            found.append(node)
    return found


def resolve_event_device(port: str, vendor_id: int, product_id: int, *, where: str,
                         what: str) -> Path:
    """The node ``port`` names (``keyboard``: the one with these ids; or a path),
    checked to be ``what`` by its ids. LinkError naming the port otherwise."""
    ids = f"{vendor_id:04x}:{product_id:04x}"
    if port == "keyboard":
        found = find_event_devices(vendor_id, product_id)
        if not found:
            raise LinkError(f"no input device {ids} ({what}): is the cable plugged in and in "
                            "keyboard mode?", where=where)
        if len(found) > 1:
            names = ", ".join(str(p) for p in found)
            raise LinkError(f"several {what} cables ({names}): name one as the port", where=where)
        return found[0]
    node = Path(port)
    actual = device_ids(node)
    if actual is None:
        raise LinkError(f"{port} is not an input event device known to the kernel (no "
                        f"{sysfs_dir(node)})", where=where)
    if actual != (vendor_id, product_id):
        raise LinkError(f"{port} is device {actual[0]:04x}:{actual[1]:04x}, not a {what} "
                        f"({ids}): refusing to read another keyboard", where=where)
    return node


def open_event_device(node: Path, *, where: str) -> int:
    """A non-blocking descriptor on ``node``, grabbed so that the typed values go to
    us only (not into whatever window the operator has open)."""
    try:
        fd = os.open(node, os.O_RDONLY | os.O_NONBLOCK)
    except OSError as exc:
        hint = {
            errno.EACCES: " (permission denied: add the user to the 'input' group)",
            errno.ENOENT: " (no such device: unplugged?)",
        }.get(exc.errno or 0, "")
        raise LinkError(f"cannot open {node}: {exc.strerror}{hint}", where=where) from exc
    try:
        fcntl.ioctl(fd, EVIOCGRAB, 1)
    except OSError as exc:
        if exc.errno == errno.EBUSY:
            os.close(fd)
            raise LinkError(f"{node} is grabbed by another program", where=where) from exc
        # Not an evdev node (ENOTTY/EINVAL: the simulator's pipe): nothing to grab.
        log.debug("%s: no exclusive grab of %s (%s)", where, node, exc.strerror)
    return fd
