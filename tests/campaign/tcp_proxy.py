"""A TCP proxy on loopback between the controller client and a Modbus server, that
drops the connection on cue: the shop floor's switch that reboots, the cable that is
pulled, the server that answers slowly. Real sockets on both sides; only the cue is
the test's."""

from __future__ import annotations

import contextlib
import select
import socket
import struct
import threading
import time


class FaultyProxy:
    """Forwards ``127.0.0.1:port`` to ``upstream``.

    ``reset_at``: on the client's Nth request (counted from 1) every connection is
    reset (RST, as a peer that vanished sends); ``stay_down``: from then on the port
    refuses connections until :meth:`come_back`; ``delay_s``: each answer is held
    back this long (a server that answers slowly).
    """

    def __init__(self, upstream: tuple[str, int], *, reset_at: int | None = None,
                 stay_down: bool = False, delay_s: float = 0.0) -> None:
        self.upstream = upstream
        self.reset_at = reset_at
        self.stay_down = stay_down
        self.delay_s = delay_s
        self.requests = 0
        self.resets = 0
        self.port = 0
        self._listener: socket.socket | None = None
        self._pairs: list[tuple[socket.socket, socket.socket]] = []
        self._lock = threading.Lock()
        self._closing = False
        self._thread: threading.Thread | None = None

    # ------------------------------------------------------------ life cycle
    def start(self) -> FaultyProxy:
        self._listen()
        return self

    def close(self) -> None:
        self._closing = True
        self._stop_listening()
        self._drop_all(reset=False)

    def __enter__(self) -> FaultyProxy:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.close()

    def cut(self) -> None:
        """Every connection reset now (and the port closed, with ``stay_down``)."""
        self._cut()

    def come_back(self) -> None:
        """The outage is over: the port accepts connections again."""
        self.stay_down = False
        self.reset_at = None
        self._listen()

    # ------------------------------------------------------------ internals
    def _listen(self) -> None:
        listener = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        listener.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        listener.bind(("127.0.0.1", self.port))
        listener.listen(8)
        self.port = listener.getsockname()[1]
        self._listener = listener
        self._thread = threading.Thread(target=self._accept, args=(listener,), daemon=True,
                                        name="faulty-proxy")
        self._thread.start()

    def _stop_listening(self) -> None:
        listener, self._listener = self._listener, None
        if listener is not None:
            with contextlib.suppress(OSError):
                listener.shutdown(socket.SHUT_RDWR)
            listener.close()

    def _accept(self, listener: socket.socket) -> None:
        while True:
            try:
                client, _ = listener.accept()
            except OSError:
                return  # the listener was closed
            server = socket.create_connection(self.upstream)
            with self._lock:
                self._pairs.append((client, server))
            threading.Thread(target=self._pump, args=(client, server), daemon=True).start()

    def _pump(self, client: socket.socket, server: socket.socket) -> None:
        with contextlib.suppress(OSError, ValueError):
            while True:
                ready, _, _ = select.select([client, server], [], [], 0.5)
                if self._closing:
                    return
                for sock in ready:
                    data = sock.recv(4096)
                    if not data:
                        self._drop(client, server, reset=False)
                        return
                    if sock is client:
                        self.requests += 1
                        if self.reset_at is not None and self.requests == self.reset_at:
                            self._cut()
                            return
                        server.sendall(data)
                    else:
                        if self.delay_s:
                            time.sleep(self.delay_s)
                        client.sendall(data)

    def _cut(self) -> None:
        self.resets += 1
        if self.stay_down:
            self._stop_listening()
        self._drop_all(reset=True)

    def _drop_all(self, *, reset: bool) -> None:
        with self._lock:
            pairs, self._pairs = self._pairs, []
        for client, server in pairs:
            self._drop(client, server, reset=reset)

    @staticmethod
    def _drop(client: socket.socket, server: socket.socket, *, reset: bool) -> None:
        if reset:  # linger 0: close sends RST, as a connection torn down mid-way
            with contextlib.suppress(OSError):
                client.setsockopt(socket.SOL_SOCKET, socket.SO_LINGER, struct.pack("ii", 1, 0))
        for sock in (client, server):
            with contextlib.suppress(OSError):
                sock.close()
