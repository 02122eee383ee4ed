"""The simulated 01A interface (a DMX-1 / MUX-10 multiplexer, or one gauge's
interface): the instrument side of :mod:`ogacq_drivers.indicators.mitutoyo_01a`.

It answers a channel's request (``1\\r``) with that channel's reply, a channel it
does not serve with ``911`` (no data from the gauge), ``V\\r`` with its device
information, and ignores anything else (INSTRUMENTS.md, 01A).
"""

from __future__ import annotations

import logging

from ogacq_drivers.indicators.mitutoyo_01a import BUSY_CODE, encode_error, encode_request
from ogacq_drivers.sim.gauges import LineDevice

log = logging.getLogger(__name__)

NO_DATA = "911"  # INSTRUMENTS.md 01A errors (L): no data from the gauge
DEVICE_INFO = b"SIM-ITN 01A simulated interface 1.0\r"  # what V answers: no source (ours)


class Mitutoyo01ADevice(LineDevice):
    """An 01A interface: one request, one reply."""

    DEFAULT_CHANNEL = "1"
    MAX_DECIMALS = 6  # 8 characters, a point and a digit before it
    DEFAULT_ERROR = NO_DATA
    BUSY_CODE = BUSY_CODE

    @classmethod
    def check_channel(cls, channel: str) -> None:
        encode_request(channel)  # ValueError when not a channel id

    def on_line(self, command: str) -> None:
        if command == "V":
            if not self.gauge.silent:
                self.gauge.send(DEVICE_INFO)
        elif command in self.gauge.channels:
            self.gauge.emit(command)
        elif len(command) == 1 and command.isalnum():
            self.gauge.send(encode_error(NO_DATA))  # nothing on that channel
        else:
            log.debug("%s: ignoring request %r", self.gauge.name, command)

    def error_frame(self, code: str, channel: str) -> bytes:
        return encode_error(code)
