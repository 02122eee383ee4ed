"""An in-process null-modem cable: two pseudo-terminals joined by a relay thread.

A pty pair has one usable path (the slave), so a simulated serial device and
the client under test cannot both open "the port". Like
``socat pty,raw pty,raw``, :class:`PtyBridge` opens two pty pairs and copies
bytes between their masters; the simulated device opens ``server_path`` and
the client opens ``client_path``.

With ``baudrate`` set, the bridge paces the bytes as a serial line would:
each byte leaves ``bits_per_byte / baudrate`` seconds after the previous one
(in both directions, and a byte cannot leave before it arrived). The devices
on either end then need not know about baud rates, and the wire time seen by a
client is the real one.

Bytes sent while nobody has the far end open are kept by the kernel up to the
pty buffer size, then dropped, as on an unconnected line.
"""

from __future__ import annotations

import collections
import contextlib
import errno
import logging
import os
import select
import threading
import time
import tty
from dataclasses import dataclass, field

from ogacq_drivers.threads import leave_interrupts_to_the_main_thread

log = logging.getLogger(__name__)

_READ_SIZE = 4096


@dataclass
class _Direction:
    """Bytes travelling one way, each with the time it is due at the far end."""

    name: str
    source_fd: int
    sink_fd: int
    byte_s: float  # 0: no pacing
    queue: collections.deque[tuple[float, int]] = field(default_factory=collections.deque)
    wire_free_s: float = 0.0
    relayed: int = 0
    dropped: int = 0

    def accept(self, data: bytes, now: float) -> None:
        if self.byte_s == 0:
            self.queue.extend((now, b) for b in data)
            return
        t = max(now, self.wire_free_s)
        for b in data:
            t += self.byte_s
            self.queue.append((t, b))
        self.wire_free_s = t

    def next_due(self) -> float | None:
        return self.queue[0][0] if self.queue else None

    def deliver(self, now: float) -> None:
        due = bytearray()
        while self.queue and self.queue[0][0] <= now:
            due.append(self.queue.popleft()[1])
        if not due:
            return
        try:
            written = os.write(self.sink_fd, due)
        except BlockingIOError:
            written = 0
        except OSError as exc:
            if exc.errno != errno.EIO:
                raise
            written = 0
        self.relayed += written
        if written < len(due):
            self.dropped += len(due) - written
            log.debug("pty bridge %s: far end not reading, %d bytes dropped", self.name,
                      len(due) - written)


class PtyBridge:
    """Two pty pairs with bytes relayed between their masters by a thread."""

    def __init__(self, *, baudrate: int | None = None, bits_per_byte: int = 10) -> None:
        if baudrate is not None and baudrate <= 0:
            raise ValueError(f"pty bridge: baudrate must be positive, got {baudrate}")
        self.baudrate = baudrate
        self.bits_per_byte = bits_per_byte
        self._fds: list[int] = []
        self._thread: threading.Thread | None = None
        self._stop = threading.Event()
        self._wake_r = self._wake_w = -1
        self.server_path = ""
        self.client_path = ""
        self._directions: list[_Direction] = []

    @property
    def byte_time_s(self) -> float:
        """Seconds one byte occupies the simulated line (0 without pacing)."""
        return self.bits_per_byte / self.baudrate if self.baudrate else 0.0

    def start(self) -> PtyBridge:
        if self._thread is not None:
            return self
        server_master, server_slave = os.openpty()
        client_master, client_slave = os.openpty()
        self._fds = [server_master, server_slave, client_master, client_slave]
        # Raw mode before anyone opens the slaves, so no echo or CR/LF mangling
        # happens to bytes that arrive first; holding the slaves open keeps the
        # masters readable (no EIO) while the ends are closed and reopened.
        for fd in (server_slave, client_slave):
            tty.setraw(fd)
        for fd in (server_master, client_master):
            os.set_blocking(fd, False)
        self.server_path = os.ttyname(server_slave)
        self.client_path = os.ttyname(client_slave)
        self._wake_r, self._wake_w = os.pipe()
        self._directions = [
            _Direction("client->server", client_master, server_master, self.byte_time_s),
            _Direction("server->client", server_master, client_master, self.byte_time_s),
        ]
        self._stop.clear()
        self._thread = threading.Thread(target=self._relay, name="pty-bridge", daemon=True)
        self._thread.start()
        log.info("pty bridge: device side %s, client side %s, %s", self.server_path,
                 self.client_path, f"paced at {self.baudrate} baud" if self.baudrate else "unpaced")
        return self

    def stop(self) -> None:
        if self._thread is None:
            return
        self._stop.set()
        os.write(self._wake_w, b"x")
        self._thread.join(timeout=2.0)
        self._thread = None
        for fd in (*self._fds, self._wake_r, self._wake_w):
            with contextlib.suppress(OSError):
                os.close(fd)
        self._fds = []
        log.info("pty bridge %s <-> %s closed", self.server_path, self.client_path)

    def __enter__(self) -> PtyBridge:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()

    @property
    def counters(self) -> dict[str, tuple[int, int]]:
        """Bytes relayed and dropped per direction."""
        return {d.name: (d.relayed, d.dropped) for d in self._directions}

    def _relay(self) -> None:
        leave_interrupts_to_the_main_thread()
        sources = {d.source_fd: d for d in self._directions}
        while not self._stop.is_set():
            dues = [t for d in self._directions if (t := d.next_due()) is not None]
            wait = max(0.0, min(dues) - time.monotonic()) if dues else 1.0
            readable, _, _ = select.select([*sources, self._wake_r], [], [], wait)
            now = time.monotonic()
            for fd in readable:
                if fd == self._wake_r:
                    continue
                try:
                    data = os.read(fd, _READ_SIZE)
                except (BlockingIOError, InterruptedError):
                    continue
                except OSError as exc:  # EIO: nobody has the slave open; keep waiting
                    if exc.errno != errno.EIO:
                        raise
                    time.sleep(0.001)
                    continue
                sources[fd].accept(data, now)
            now = time.monotonic()
            for direction in self._directions:
                direction.deliver(now)
