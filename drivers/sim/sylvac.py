"""The simulated Sylvac instrument on an Opto-RS cable, duplex or simplex: the
instrument side of :mod:`ogacq_drivers.indicators.sylvac` and
:mod:`~ogacq_drivers.indicators.sylvac_simplex`.

Source: Sylvac "User's manual for OPTO-RS cable connections" (Sylvac / Bowers Opto
instruments manual, pp. 12-13). On the duplex cable it answers ``?`` with a value,
takes ``MM``/``IN`` as unit commands and answers anything else with ``ERR1``
(incorrect command); a value beyond its range is ``ERR3``. On the simplex cable it
takes no command (the manual: remote commands are ignored): it sends its
identification when the cable is powered (RTS high; the manual: "the id.
transmission is done only when switching ON the instrument") and a value when DTR
has been low for at least 110 ms.
"""

from __future__ import annotations

import logging
import time

from ogacq_drivers.indicators.sylvac import encode_error, encode_identification
from ogacq_drivers.sim import gauges
from ogacq_drivers.sim.gauges import GaugeEndpoint, LineDevice

log = logging.getLogger(__name__)

INCORRECT_COMMAND, OUT_OF_RANGE = 1, 3  # ERR1, ERR3 (the manual's error list)


class SylvacDuplexDevice(LineDevice):
    """A Sylvac instrument on the duplex cable."""

    MAX_DECIMALS = 7
    DEFAULT_ERROR = str(OUT_OF_RANGE)

    @classmethod
    def shown_resolution_mm(cls, resolution_mm: float) -> float:
        # A Sylvac shows 0.001 mm unless set otherwise (RES2), and its driver pins that
        # layout; a coarser machine resolution would be a RES3 gauge.
        return min(resolution_mm, 0.001)

    def on_line(self, command: str) -> None:
        command = command.upper()
        if command == "?":
            self.gauge.emit(self.gauge.default_channel)
        elif command in ("MM", "IN"):
            self.gauge.unit = "mm" if command == "MM" else "inch"
        else:
            self.gauge.send(encode_error(INCORRECT_COMMAND))

    def overflow_frame(self) -> bytes | None:
        return encode_error(OUT_OF_RANGE)

    def error_frame(self, code: str, channel: str) -> bytes:
        return encode_error(code)


class SylvacSimplexDevice(SylvacDuplexDevice):
    """The same instrument on the simplex cable: asked by a DTR pulse, so it is
    served over RFC 2217, the one simulated transport that carries DTR."""

    TRANSPORT = "rfc2217"
    IDENTIFICATION = encode_identification("235", "1")  # a Sylvac 235, as the manual names

    def __init__(self, gauge: GaugeEndpoint) -> None:
        super().__init__(gauge)
        self._dtr_low_since: float | None = None

    def on_input(self, data: bytes) -> None:
        """Commands do not reach the instrument on a simplex cable."""

    def on_control(self, line: str, level: bool) -> None:
        if line == "rts" and level:  # the cable powers the instrument up: it says who it is
            self.gauge.send(self.IDENTIFICATION)
        elif line == "dtr" and not level:
            self._dtr_low_since = time.monotonic()
        elif line == "dtr" and level and self._dtr_low_since is not None:
            low_s = time.monotonic() - self._dtr_low_since
            self._dtr_low_since = None
            if low_s >= gauges._SIMPLEX_PULSE_S:
                self.gauge.count_request()
                self.gauge.emit(self.gauge.default_channel)
            else:
                log.debug("%s: DTR low %.0f ms, too short for a request", self.gauge.name,
                          low_s * 1e3)
