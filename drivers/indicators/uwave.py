"""Mitutoyo U-WAVE-R receiver: readings pushed by the receiver, CR-terminated.

Data frame ``DT1 GG CC ±value U`` (group, channel, unit ``M`` mm / ``I`` inch),
e.g. ``DT10000+00000011.88M`` = +11.88 mm from group 00, channel 00. The value
field is fixed-width (11 characters, floating decimal point) so that a lost
digit is a grammar error, not a different number.

Status frame ``ST1 GG CC .. SS``: a two-digit code at the end (00 battery low,
01 instrument not responding, 03 data loss, 04 transmitter disconnected, 05 no
data). The two characters before it are not documented; up to four are
accepted and logged.
"""

from __future__ import annotations

import logging
import re
import time
from dataclasses import dataclass
from decimal import ROUND_HALF_EVEN, Decimal

import serial

from drivers.errors import DeviceFault, DriverError, FrameError
from drivers.indicators.base import Reading, SerialIndicator, Unit, check_unit, to_mm

log = logging.getLogger(__name__)

VALUE_WIDTH = 11
UNIT_LETTERS: dict[bytes, Unit] = {b"M": "mm", b"I": "inch"}
BATTERY_LOW = "00"
STATUS_MEANINGS = {
    "00": "transmitter battery low",
    "01": "instrument not responding (check the gauge and its U-WAVE-T)",
    "03": "data loss (radio link)",
    "04": "transmitter disconnected (out of range or switched off?)",
    "05": "no data from the instrument",
}

_DATA = re.compile(rb"DT1([0-9]{2})([0-9]{2})([+-])([0-9.]{11})([MI])\r")
_VALUE_FIELD = re.compile(rb"[0-9]+(?:\.[0-9]+)?")
_STATUS = re.compile(rb"ST1([0-9]{2})([0-9]{2})([\x20-\x7e]{0,4}?)([0-9]{2})\r")


@dataclass(frozen=True, slots=True)
class UWaveData:
    """A pushed reading (value in the unit the frame reports)."""

    group: str
    channel: str
    value: Decimal
    decimals: int
    unit: Unit

    @property
    def gauge_id(self) -> str:
        return self.group + self.channel


@dataclass(frozen=True, slots=True)
class UWaveStatus:
    """A pushed status frame, classified."""

    group: str
    channel: str
    code: str
    meaning: str
    detail: str = ""  # the undocumented characters before the code

    @property
    def gauge_id(self) -> str:
        return self.group + self.channel

    @property
    def is_warning(self) -> bool:
        """Battery low still lets readings through; everything else stops them."""
        return self.code == BATTERY_LOW


def encode_data(
    value: float | Decimal,
    *,
    decimals: int,
    unit: Unit = "mm",
    gauge_id: str = "0000",
) -> bytes:
    """A data frame for ``value`` in ``unit``; ValueError when it does not fit."""
    if not re.fullmatch(r"[0-9]{4}", gauge_id):
        raise ValueError(f"gauge_id is group and channel, four digits, got {gauge_id!r}")
    if not 0 <= decimals <= VALUE_WIDTH - 2:
        raise ValueError(f"decimals must be 0..{VALUE_WIDTH - 2}, got {decimals}")
    letter = {"mm": "M", "inch": "I"}.get(unit)
    if letter is None:
        raise ValueError(f"unit must be 'mm' or 'inch', got {unit!r}")
    exact = Decimal(str(value)) if isinstance(value, float) else Decimal(value)
    shown = exact.quantize(Decimal(1).scaleb(-decimals), rounding=ROUND_HALF_EVEN)
    sign = "-" if shown < 0 else "+"
    field = f"{abs(shown):0{VALUE_WIDTH}.{decimals}f}"
    if len(field) != VALUE_WIDTH:
        raise ValueError(f"{value} does not fit {VALUE_WIDTH} characters")
    return f"DT1{gauge_id}{sign}{field}{letter}\r".encode("ascii")


def encode_status(code: str, *, gauge_id: str = "0000", detail: str = "00") -> bytes:
    """A status frame, e.g. ``encode_status("04") == b"ST10000" b"00" b"04\\r"``."""
    if not re.fullmatch(r"[0-9]{2}", code) or not re.fullmatch(r"[0-9]{4}", gauge_id):
        raise ValueError(f"bad status code {code!r} or gauge_id {gauge_id!r}")
    return f"ST1{gauge_id}{detail}{code}\r".encode("ascii")


def decode_frame(frame: bytes, *, where: str = "") -> UWaveData | UWaveStatus:
    """Decode a data or status frame (CR included); FrameError if it is neither."""
    status = _STATUS.fullmatch(frame)
    if status is not None:
        group, channel, detail, code = (part.decode("ascii") for part in status.groups())
        meaning = STATUS_MEANINGS.get(code, f"unknown status {code}")
        return UWaveStatus(group=group, channel=channel, code=code, meaning=meaning, detail=detail)
    data = _DATA.fullmatch(frame)
    if data is None:
        raise FrameError("not a U-WAVE data or status frame", where=where, frame=frame)
    group, channel, sign, field, letter = data.groups()
    if not _VALUE_FIELD.fullmatch(field):
        raise FrameError(
            "U-WAVE value is not digits with one decimal point", where=where, frame=frame
        )
    value = Decimal(field.decode("ascii"))
    if sign == b"-":
        value = -value
    decimals = len(field) - field.index(b".") - 1 if b"." in field else 0
    return UWaveData(
        group=group.decode("ascii"),
        channel=channel.decode("ascii"),
        value=value,
        decimals=decimals,
        unit=UNIT_LETTERS[letter],
    )


class UWaveReceiver(SerialIndicator):
    """Readings pushed by a U-WAVE-R receiver for one transmitter.

    ``channel`` selects the transmitter: ``"CC"`` (any group) or ``"GGCC"``;
    ``None`` takes frames from any transmitter (the reading records which).
    ``read`` returns the next pushed frame in arrival order; call
    ``flush_input`` (``read_stable`` does) to drop frames pushed before now.
    """

    default_timeout_s = 5.0

    def __init__(
        self,
        link: serial.SerialBase,
        *,
        where: str,
        unit: str,
        channel: str | None = None,
        timeout_s: float | None = None,
        owns_link: bool = False,
    ) -> None:
        super().__init__(link, where=where, timeout_s=timeout_s, owns_link=owns_link)
        if channel is not None and not re.fullmatch(r"[0-9]{2}|[0-9]{4}", channel):
            raise DriverError(
                f"U-WAVE channel is 'CC' or 'GGCC' digits, got {channel!r}", where=where
            )
        self.unit: Unit = check_unit(unit, where=where)
        self.channel = channel
        self._cut_by_flush = True  # opening may land mid-frame, as a flush does
        self._last_unit: Unit | None = None

    def flush_input(self) -> None:
        super().flush_input()
        self._cut_by_flush = True

    def read(self, timeout_s: float | None = None) -> Reading:
        """The next reading pushed for this transmitter.

        Raises :class:`DeviceFault` (code = status code) for a status frame
        other than battery low, which is only logged.
        """
        deadline = self._deadline(timeout_s)
        while True:
            frame, decoded = self._read_decoded(deadline, decode_frame)
            if not self._is_mine(decoded.gauge_id):
                log.debug("%s: ignoring frame from transmitter %s", self.where, decoded.gauge_id)
                continue
            if isinstance(decoded, UWaveStatus):
                if decoded.detail not in ("", "00"):
                    log.debug("%s: status frame detail %r", self.where, decoded.detail)
                if decoded.is_warning:
                    log.warning(
                        "%s: %s (transmitter %s)", self.where, decoded.meaning, decoded.gauge_id
                    )
                    continue
                raise DeviceFault(
                    f"U-WAVE status {decoded.code}: {decoded.meaning} "
                    f"(transmitter {decoded.gauge_id})",
                    code=decoded.code,
                    where=self.where,
                )
            if decoded.unit != self._last_unit:
                self._last_unit = decoded.unit
                if decoded.unit != self.unit:
                    log.warning(
                        "%s: gauge displays %s but is configured %s; values are converted "
                        "from the unit in each frame",
                        self.where,
                        decoded.unit,
                        self.unit,
                    )
            return Reading(
                value_mm=to_mm(decoded.value, decoded.unit),
                frame=frame,
                time_s=time.time(),
                channel=decoded.gauge_id,
                unit=decoded.unit,
                where=self.where,
            )

    def _is_mine(self, gauge_id: str) -> bool:
        if self.channel is None:
            return True
        if len(self.channel) == 2:
            return gauge_id[2:] == self.channel
        return gauge_id == self.channel
