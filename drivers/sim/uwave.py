"""The simulated U-WAVE-R receiver: the instrument side of
:mod:`ogacq_drivers.indicators.uwave`.

It pushes a data frame per transmitter (channel ``GGCC``) when a DATA button is
pressed (:meth:`~ogacq_drivers.sim.gauges.GaugeEndpoint.trigger`, or every
``period_s``), a status frame instead when told to (``Fault.ERROR``: code ``01``
instrument not responding unless given another, U-WAVE-R manual 99MAL216A, 6.1),
and ignores what it receives (INSTRUMENTS.md: the receiver pushes readings).
"""

from __future__ import annotations

from ogacq_drivers.indicators.uwave import encode_status
from ogacq_drivers.sim.gauges import SerialDevice


class UWaveReceiverDevice(SerialDevice):
    """A receiver with one or more transmitters."""

    DEFAULT_CHANNEL = "0000"  # group 00, channel 00
    MAX_DECIMALS = 9  # 11 characters, a point and a digit before it
    FREE_RUNNING = True
    PRESSED = True
    DEFAULT_ERROR = "01"

    @classmethod
    def check_channel(cls, channel: str) -> None:
        if not (len(channel) == 4 and channel.isdigit()):
            raise ValueError(f"U-WAVE channel is group and channel 'GGCC', got {channel!r}")

    def error_frame(self, code: str, channel: str) -> bytes:
        return encode_status(code, gauge_id=channel)
