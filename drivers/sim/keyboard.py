"""A simulated USB-ITN cable in keyboard mode: key events in a device node.

Without ``/dev/uinput`` (none in the sandbox, and creating input devices needs
root), the cable is an input-event stream written into a named pipe standing for
``/dev/input/eventN``, inside a temporary tree that also holds the sysfs entries
the kernel would publish (``sys/class/input/eventN/device/id/vendor``...). The
driver finds, checks and reads it with the code it uses on a real system
(:mod:`ogacq_drivers.input_link`); only the grab ioctl has nothing to grab.

Each press of the data switch (every ``period_s``, or :meth:`trigger`) types the
displayed value and Enter as ``struct input_event`` records (press, release, a
SYN_REPORT after each). One line is written at once (well under PIPE_BUF, so
atomically) or dropped when the reader lags that far, as evdev drops events.
Faults: silence, garbled (a letter among the digits), stale, inch, unplug (the
node disappears: the reader sees end of file).
"""

from __future__ import annotations

import contextlib
import logging
import os
import shutil
import tempfile
import threading
import time
from collections.abc import Callable
from decimal import Decimal
from pathlib import Path

from ogacq_drivers.atomic import write_atomically
from ogacq_drivers.indicators import usb_itn
from ogacq_drivers.indicators.base import Unit
from ogacq_drivers.indicators.usb_itn_keyboard import EV_KEY, key_events
from ogacq_drivers.input_link import EVENT
from ogacq_drivers.sim.gauges import Fault, UsbCableGauge
from ogacq_drivers.threads import leave_interrupts_to_the_main_thread

log = logging.getLogger(__name__)

EV_SYN = 0  # linux/input-event-codes.h; SYN_REPORT is code 0
EV_MSC, MSC_SCAN = 4, 4  # the scan code a HID keyboard reports before each key event


class KeyboardEndpoint(UsbCableGauge):
    """One simulated keyboard-mode cable; clients open :attr:`port` (a device node path)."""

    protocol = "usb-itn-keyboard"

    def __init__(self, value_source: Callable[[], float], *, resolution_mm: float = 0.001,
                 unit: Unit = "mm", period_s: float | None = None, name: str | None = None,
                 vendor_id: int = usb_itn.VENDOR_ID, product_id: int = usb_itn.PRODUCT_ID) -> None:
        super().__init__(value_source, resolution_mm=resolution_mm, unit=unit, name=name)
        self.period_s = period_s
        self.ids = (vendor_id, product_id)
        self._root: Path | None = None
        self._fd = -1
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None

    # ---------------------------------------------------------------- lifecycle
    def _started_port(self) -> str:
        return "" if self._root is None else str(self._root / "dev" / "input" / "event0")

    def start(self) -> KeyboardEndpoint:
        if self._root is not None:
            return self
        root = Path(tempfile.mkdtemp(prefix="ogacq-keyboard-"))
        ids = root / "sys" / "class" / "input" / "event0" / "device" / "id"
        ids.mkdir(parents=True)
        # sysfs writes the ids as four hex digits and a newline.
        for path, text in ((ids / "vendor", f"{self.ids[0]:04x}\n"),
                           (ids / "product", f"{self.ids[1]:04x}\n"),
                           (ids / "bustype", "0003\n"),  # BUS_USB
                           (ids.parent / "name", "Mitutoyo USB-ITN (simulated)\n")):
            write_atomically(path, text.encode("ascii"))
        node = root / "dev" / "input" / "event0"
        node.parent.mkdir(parents=True)
        os.mkfifo(node)
        # Read-write: opening never blocks, and the reader sees end of file only
        # when this end closes (the unplug).
        self._fd = os.open(node, os.O_RDWR | os.O_NONBLOCK)
        self._root = root
        if self.period_s:
            self._thread = threading.Thread(target=self._press_periodically, daemon=True,
                                            name=self.name)
            self._thread.start()
        return self

    def close(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=2)
        self._unplug_now()
        if self._root is not None:
            shutil.rmtree(self._root, ignore_errors=True)

    # ------------------------------------------------------------------- faults
    NAME = "sim usb-itn keyboard"
    CABLE = "a keyboard cable"
    SHOWS = (Fault.SILENCE, Fault.GARBLED, Fault.INCH)
    PRESSED = True

    def _push_stale(self, value_mm: float, count: int) -> None:
        for _ in range(count):
            self._type(_text(*self._shown(value_mm, self.unit)))

    def unplug(self) -> None:
        self.unplugged = True
        self._unplug_now()

    def trigger(self) -> None:
        """The data switch is pressed once."""
        faults = self._take_faults()
        if Fault.SILENCE in faults or self.unplugged:
            return
        text = _text(*self._shown_now(faults))
        if Fault.GARBLED in faults:
            middle = len(text) // 2
            text = text[:middle] + "A" + text[middle + 1 :]
        self._type(text)

    # ----------------------------------------------------------------- typing
    def _press_periodically(self) -> None:
        leave_interrupts_to_the_main_thread()
        assert self.period_s
        while not self._stop.wait(self.period_s):
            if self.unplugged:
                return
            self.trigger()

    def _type(self, text: str) -> None:
        now = time.time()
        sec, usec = int(now), int((now % 1) * 1e6)
        records = bytearray()
        for code, value in key_events(text):
            records += EVENT.pack(sec, usec, EV_MSC, MSC_SCAN, code)
            records += EVENT.pack(sec, usec, EV_KEY, code, value)
            records += EVENT.pack(sec, usec, EV_SYN, 0, 0)
        with self._lock:
            if self._fd < 0:
                return
            try:
                os.write(self._fd, records)  # < PIPE_BUF: all or nothing
            except BlockingIOError:
                log.debug("%s: reader lagging, a typed line dropped", self.name)

    def _unplug_now(self) -> None:
        with self._lock:
            if self._fd >= 0:
                with contextlib.suppress(OSError):
                    os.close(self._fd)
                self._fd = -1
        if self._root is not None:  # the kernel removes the node and its sysfs entry
            with contextlib.suppress(OSError):
                os.unlink(self._root / "dev" / "input" / "event0")
            shutil.rmtree(self._root / "sys" / "class" / "input" / "event0", ignore_errors=True)


def _text(shown: Decimal, decimals: int) -> str:
    """What the cable types for a shown value."""
    return f"{shown:.{decimals}f}"
