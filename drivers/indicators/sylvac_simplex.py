"""Sylvac Opto-RS simplex cable: same frames as the duplex cable, other wiring.

Source: Sylvac "User's manual for OPTO-RS cable connections" (Bowers Group /
Sylvac Opto instruments user manual, pages 12-13), "Simplex cable":

- positive supply from RTS (pin 7) ON (high); negative supply from TXD (pin 3),
  which stays idle (nothing is ever written to it);
- data (instrument to PC) on RXD, 4800 baud 7E2 like the duplex cable;
- data request: DTR (pin 4) is normally ON (high); turning it OFF (low) for at
  least 110 ms asks for one value. The instrument ignores commands.

The request is a change of a control line, so the port must carry DTR: a real
serial port or USB adapter, or a network serial server speaking RFC 2217
(``rfc2217://host:port``, which is how the simulator serves this cable). A
pseudo-terminal or a raw TCP socket has no DTR: the driver says so at once.
"""

from __future__ import annotations

import errno
import time

from ogacq_drivers.errors import LinkError
from ogacq_drivers.indicators.base import Reading, link_errors
from ogacq_drivers.indicators.sylvac import SylvacOptoRS, read_reply

#: The manual's minimum is 110 ms; 10 ms margin for the USB adapter's latency.
REQUEST_PULSE_S = 0.12


class SylvacSimplex(SylvacOptoRS):
    """A Sylvac gauge on an Opto-RS simplex cable (DTR-pulse request)."""

    request_pulse_s = REQUEST_PULSE_S

    def _power_cable(self) -> None:
        """RTS high powers the cable; DTR high is the resting (no request) state."""
        self._set_lines("powering the simplex cable (RTS high, DTR high)", rts=True, dtr=True)

    def read(self, timeout_s: float | None = None) -> Reading:
        """Pulse DTR low for 120 ms, then decode the value the instrument sends."""
        deadline = self._deadline(timeout_s)
        self.flush_input()
        self._set_lines("requesting a value (DTR low)", dtr=False)
        time.sleep(self.request_pulse_s)
        self._set_lines("ending the request (DTR high)", dtr=True)
        return self._reading(read_reply(lambda: self._read_frame(deadline), where=self.where))

    def _set_lines(self, action: str, **lines: bool) -> None:
        try:
            for name, level in lines.items():
                setattr(self.link, name, level)
        except OSError as exc:
            if exc.errno in (errno.ENOTTY, errno.EINVAL):
                raise LinkError(f"{self.link.port} has no DTR/RTS lines ({exc.strerror}): a "
                                "simplex cable is asked for values by DTR; use a real serial "
                                "port or an RFC 2217 server", where=self.where) from exc
            with link_errors(self.where, action):
                raise
        except Exception as exc:  # pyserial wraps some failures (rfc2217: SerialException)
            with link_errors(self.where, action):
                raise OSError(str(exc)) from exc
