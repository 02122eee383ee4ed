"""The simulated Digimatic USB bridge: the instrument side of
:mod:`ogacq_drivers.indicators.digimatic`.

Polled, it answers any byte with one frame; streaming, it sends a frame every
10 ms (INSTRUMENTS.md: "some bridges answer any byte with one frame, others stream
every ~10 ms") and ignores what it receives. A Digimatic frame has no error code.
"""

from __future__ import annotations

from decimal import Decimal

from ogacq_drivers.indicators.base import Unit
from ogacq_drivers.indicators.digimatic import encode_frame
from ogacq_drivers.sim.gauges import GaugeEndpoint, SerialDevice

STREAM_PERIOD_S = 0.01  # INSTRUMENTS.md: every ~10 ms


class DigimaticBridgeDevice(SerialDevice):
    """A bridge, polled or ``streaming``; ``digimatic2``: eight-digit Digimatic 2
    frames (99MAF600B 6.2.1)."""

    MAX_DECIMALS = 5  # d12, the decimal position, is 0-5 (99MAF600B 6.2.1)
    FREE_RUNNING = True

    def __init__(self, gauge: GaugeEndpoint, *, streaming: bool = False,
                 digimatic2: bool = False) -> None:
        super().__init__(gauge)
        self.streaming = streaming
        self.digimatic2 = digimatic2

    @property
    def default_period_s(self) -> float | None:
        return STREAM_PERIOD_S if self.streaming else None

    def on_input(self, data: bytes) -> None:
        if self.streaming:
            return
        for _ in data:  # a polled bridge answers every byte
            self.gauge.count_request()
            self.gauge.emit(self.gauge.default_channel)

    def value_frame(self, value: Decimal, *, decimals: int, unit: Unit, channel: str,
                    inch_code: str) -> bytes:
        return encode_frame(value, decimals=decimals, unit=unit, inch_nibble=inch_code,
                            digimatic2=self.digimatic2)
