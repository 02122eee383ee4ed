"""Mitutoyo U-WAVE-R receiver: readings pushed by the receiver, CR-terminated.

Data frame ``DT1 GG CC ±value U`` (group, channel, unit ``M`` mm / ``I`` inch /
``0`` no unit), e.g. ``DT10000+00000011.88M`` = +11.88 mm from group 00, channel
00 (../shared/spec/INSTRUMENTS.md; unit ``0`` from the U-WAVE-R user's manual
No. 99MAL216A, section 6.1, as quoted in issue 12). The value field is
fixed-width (11 characters, floating decimal point) so that a lost digit is a
grammar error, not a different number. A frame with unit ``0`` carries no unit:
the unit recorded at setup applies and the decimals must fit it, as for 01A.

Status frame, 19 characters and CR (manual 99MAL216A, section 6.1)::

    ST1 GG CC IIIIIIIIII SS
    ST1 01 02 FFFFFFFFFF 04      transmitter 0102 disconnected, id unknown

``IIIIIIIIII`` is the transmitter's 10-digit id, or ``FFFFFFFFFF`` when the
receiver does not know it. INSTRUMENTS.md writes the frame ``ST1GGCC..SS``
(two characters before the code); the manual's 10-character id wins, and a
frame shaped like INSTRUMENTS.md's is refused as garbled.
"""

from __future__ import annotations

import logging
import re
from collections.abc import Iterable
from dataclasses import dataclass
from decimal import ROUND_HALF_EVEN, Decimal

import serial

from ogacq_drivers.errors import DeviceFault, DeviceTimeout, DriverError, FrameError
from ogacq_drivers.indicators.backend import Codec, Decoded, Example
from ogacq_drivers.indicators.base import (
    Reading,
    SerialIndicator,
    Unit,
    check_decimals,
    reading_of,
    warn_other_unit,
)

log = logging.getLogger(__name__)

VALUE_WIDTH = 11
# Unit character of a data frame; "0" = the instrument sends no unit (99MAL216A 6.1).
UNIT_LETTERS: dict[bytes, Unit | None] = {b"M": "mm", b"I": "inch", b"0": None}
UNKNOWN_ID = "FFFFFFFFFF"  # transmitter id the receiver does not know (99MAL216A 6.1)
BATTERY_LOW = "00"
# Codes of 99MAL216A section 6.1 (the list issue 12 quotes). The wording of 00, 01,
# 03, 04, 05 follows INSTRUMENTS.md; for 02, 50, 51 and 99 we had no text of the
# manual at hand (no source for the wording), so the message gives the code and
# points to the manual.
STATUS_MEANINGS = {
    "00": "transmitter battery low",
    "01": "instrument not responding (check the gauge and its U-WAVE-T)",
    "02": "instrument error (status 02, see the U-WAVE-R manual 99MAL216A, 6.1)",
    "03": "data loss (radio link)",
    "04": "transmitter disconnected (out of range or switched off?)",
    "05": "no data from the instrument",
    "50": "transmitter status 50 (see the U-WAVE-R manual 99MAL216A, 6.1)",
    "51": "transmitter status 51 (see the U-WAVE-R manual 99MAL216A, 6.1)",
    "99": "receiver error 99 (see the U-WAVE-R manual 99MAL216A, 6.1)",
}
# What each status says of the readings, from its meaning above: 00 is a warning
# only (the data frames carry on). 01, 03, 04 and 05 report a reading that did not
# arrive (the instrument did not answer, the radio lost the frame, the transmitter
# dropped out, nothing came from the instrument): a data frame the receiver pushes
# after one is a new measurement, so a read waits on for it until its deadline and
# names the status only if none comes (an independent reader's notes of a live
# capture, leank-spc's U-Wave guide, see status frames among the data frames of a
# working receiver and read on past them). 02 (an instrument error), 50, 51, 99 and any
# code not listed concern the instrument or the receiver themselves, which we
# cannot vouch for: they stop the read at once.
READING_LOST = frozenset({"01", "03", "04", "05"})

_DATA = re.compile(rb"DT1([0-9]{2})([0-9]{2})([+-])([0-9.]{11})([MI0])\r")
_VALUE_FIELD = re.compile(rb"[0-9]+(?:\.[0-9]+)?")
# 3 + 2 + 2 + 10 + 2 = 19 characters, then CR. The id is digits or all F.
_STATUS = re.compile(rb"ST1([0-9]{2})([0-9]{2})([0-9]{10}|F{10})([0-9]{2})\r")


@dataclass(frozen=True, slots=True)
class UWaveData:
    """A pushed reading (value in the unit the frame reports)."""

    group: str
    channel: str
    value: Decimal
    decimals: int
    unit: Unit | None  # None: the frame's unit character is "0" (no unit)

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
    transmitter_id: str = UNKNOWN_ID

    @property
    def gauge_id(self) -> str:
        return self.group + self.channel

    @property
    def is_warning(self) -> bool:
        """Battery low still lets readings through."""
        return self.code == BATTERY_LOW

    @property
    def reading_lost(self) -> bool:
        """A reading that did not arrive: the next data frame is a new one (READING_LOST)."""
        return self.code in READING_LOST


def encode_data(value: float | Decimal, *, decimals: int, unit: Unit | None = "mm",
                gauge_id: str = "0000") -> bytes:
    """A data frame for ``value`` in ``unit`` (None: unit character ``0``);
    ValueError when it does not fit."""
    if not re.fullmatch(r"[0-9]{4}", gauge_id):
        raise ValueError(f"gauge_id is group and channel, four digits, got {gauge_id!r}")
    if not 0 <= decimals <= VALUE_WIDTH - 2:
        raise ValueError(f"decimals must be 0..{VALUE_WIDTH - 2}, got {decimals}")
    letter = {"mm": "M", "inch": "I", None: "0"}.get(unit)
    if letter is None:
        raise ValueError(f"unit must be 'mm', 'inch' or None (no unit), got {unit!r}")
    exact = Decimal(str(value)) if isinstance(value, float) else Decimal(value)
    shown = exact.quantize(Decimal(1).scaleb(-decimals), rounding=ROUND_HALF_EVEN)
    sign = "-" if shown < 0 else "+"
    field = f"{abs(shown):0{VALUE_WIDTH}.{decimals}f}"
    if len(field) != VALUE_WIDTH:
        raise ValueError(f"{value} does not fit {VALUE_WIDTH} characters")
    return f"DT1{gauge_id}{sign}{field}{letter}\r".encode("ascii")


def same_indicator(a: str | None, b: str | None) -> bool:
    """Whether gauges set to channels ``a`` and ``b`` of one receiver may take the same
    transmitter's frames: no channel takes any (until a second transmitter is heard),
    ``CC`` any group's channel CC, ``GGCC`` that one (``UWaveReceiver._is_mine``)."""
    if a is None or b is None:
        return True
    if len(a) == 2 or len(b) == 2:
        return a[-2:] == b[-2:]
    return a == b


def encode_status(code: str, *, gauge_id: str = "0000", transmitter_id: str = UNKNOWN_ID) -> bytes:
    """A 19-character status frame, e.g. ``encode_status("04") ==
    b"ST10000FFFFFFFFFF04\\r"``."""
    if not re.fullmatch(r"[0-9]{2}", code) or not re.fullmatch(r"[0-9]{4}", gauge_id):
        raise ValueError(f"bad status code {code!r} or gauge_id {gauge_id!r}")
    if not re.fullmatch(r"[0-9]{10}|F{10}", transmitter_id):
        raise ValueError(f"transmitter id is 10 digits or FFFFFFFFFF, got {transmitter_id!r}")
    return f"ST1{gauge_id}{transmitter_id}{code}\r".encode("ascii")


def decode_frame(frame: bytes, *, where: str = "") -> UWaveData | UWaveStatus:
    """Decode a data or status frame (CR included); FrameError if it is neither."""
    status = _STATUS.fullmatch(frame)
    if status is not None:
        group, channel, ident, code = (part.decode("ascii") for part in status.groups())
        meaning = STATUS_MEANINGS.get(code, f"unknown status {code}")
        return UWaveStatus(group=group, channel=channel, code=code, meaning=meaning,
                           transmitter_id=ident)
    data = _DATA.fullmatch(frame)
    if data is None:
        raise FrameError("not a U-WAVE data or status frame", where=where, frame=frame)
    group, channel, sign, field, letter = data.groups()
    if not _VALUE_FIELD.fullmatch(field):
        raise FrameError("U-WAVE value is not digits with one decimal point", where=where,
                         frame=frame)
    value = Decimal(field.decode("ascii"))
    if sign == b"-":
        value = -value
    decimals = len(field) - field.index(b".") - 1 if b"." in field else 0
    return UWaveData(group=group.decode("ascii"), channel=channel.decode("ascii"), value=value,
                     decimals=decimals, unit=UNIT_LETTERS[letter])


def status_fault(status: UWaveStatus, *, where: str = "") -> DeviceFault:
    """The error a status frame stops a reading with."""
    ident = "" if status.transmitter_id == UNKNOWN_ID else f", id {status.transmitter_id}"
    return DeviceFault(f"U-WAVE status {status.code}: {status.meaning} (transmitter "
                       f"{status.gauge_id}{ident})", code=status.code, where=where)


def decode(frame: bytes, *, where: str = "") -> Decoded:
    """The codec's decode: a data frame's value; every status frame is a DeviceFault
    here, battery low included (the receiver, which can wait for the next frame,
    only logs that one)."""
    decoded = decode_frame(frame, where=where)
    if isinstance(decoded, UWaveStatus):
        raise status_fault(decoded, where=where)
    return Decoded(decoded.value, decoded.decimals, decoded.unit, decoded.gauge_id)


def encode(value: Decimal, *, decimals: int, unit: Unit = "mm", channel: str = "") -> bytes:
    """The codec's encode: ``channel`` is the transmitter, GGCC (default 0000)."""
    return encode_data(value, decimals=decimals, unit=unit, gauge_id=channel or "0000")


CODEC = Codec(decode, encode, examples=(
    Example(b"DT10000+00000011.88M\r", "INSTRUMENTS.md U-WAVE-R: +11.88 mm, group 00 "
            "channel 00", value_mm=11.88),
    Example(b"DT10000+00000011.880\r", "the frame above with unit character 0, no unit "
            "sent (U-WAVE-R manual 99MAL216A, 6.1, as quoted in issue 12)", value_mm=11.88),
    Example(b"ST10102FFFFFFFFFF04\r", "99MAL216A, 6.1 status layout: transmitter 0102 "
            "disconnected, id unknown", error=DeviceFault),
), fixed_width=True)


class UWaveReceiver(SerialIndicator):
    """Readings pushed by a U-WAVE-R receiver for one transmitter.

    ``channel`` selects the transmitter: ``"CC"`` (any group) or ``"GGCC"``;
    ``None`` takes the frames of the one transmitter the receiver hears (the reading
    records which). Once frames of a second transmitter arrive, a gauge with no channel
    could be reading either one, so every read fails until the channel is given.
    ``read`` returns the next pushed frame in arrival order; call
    ``flush_input`` (``read_stable`` does) to drop frames pushed before now."""

    default_timeout_s = 5.0

    def __init__(self, link: serial.Serial, *, where: str, unit: str, channel: str | None = None,
                 decimals: int | Iterable[int] | None = None, timeout_s: float | None = None,
                 owns_link: bool = False) -> None:
        super().__init__(link, where=where, timeout_s=timeout_s, owns_link=owns_link)
        if channel is not None and not re.fullmatch(r"[0-9]{2}|[0-9]{4}", channel):
            raise DriverError(f"U-WAVE channel is 'CC' or 'GGCC' digits, got {channel!r}",
                              where=where)
        self._set_unit(unit, decimals)
        self.channel = channel
        self._cut_by_flush = True  # opening may land mid-frame, as a flush does
        self._last_unit: Unit | None = None
        self._heard: str | None = None  # with no channel: the transmitter heard first
        self._second: str | None = None  # ... and another one heard after it

    def flush_input(self) -> None:
        super().flush_input()
        self._cut_by_flush = True

    def read(self, timeout_s: float | None = None) -> Reading:
        """The next reading pushed for this transmitter.

        Battery low is only logged. A status saying a reading was lost (READING_LOST)
        is logged and the read waits on for the next data frame: :class:`DeviceFault`
        (code = status code) only when none comes before the deadline. Any other
        status raises it at once."""
        deadline = self._deadline(timeout_s)
        lost: UWaveStatus | None = None
        while True:
            try:
                frame, decoded = self._read_decoded(deadline, decode_frame)
            except DeviceTimeout as exc:
                if lost is None:
                    raise
                raise status_fault(lost, where=self.where) from exc
            if not self._is_mine(decoded.gauge_id):
                log.debug("%s: ignoring frame from transmitter %s", self.where, decoded.gauge_id)
                continue
            self._check_one_transmitter(decoded.gauge_id)
            if isinstance(decoded, UWaveStatus):
                if decoded.is_warning:
                    log.warning("%s: %s (transmitter %s)", self.where, decoded.meaning,
                                decoded.gauge_id)
                    continue
                if decoded.reading_lost:
                    log.warning("%s: %s (transmitter %s); waiting for its next reading",
                                self.where, decoded.meaning, decoded.gauge_id)
                    lost = decoded
                    continue
                raise status_fault(decoded, where=self.where)
            return reading_of(decoded.value, self._unit_of(decoded, frame), frame,
                              channel=decoded.gauge_id, where=self.where)

    def _unit_of(self, decoded: UWaveData, frame: bytes) -> Unit:
        """The frame's unit; for unit ``0`` (none sent) the configured one, whose
        decimal layout the value must fit, as with the unit-less 01A frames."""
        if decoded.unit is None:
            check_decimals(decoded.decimals, self.unit, self._accepted_decimals,
                           where=self.where, frame=frame)
            return self.unit
        if decoded.unit != self._last_unit:
            self._last_unit = decoded.unit
            warn_other_unit(decoded.unit, self.unit, where=self.where)
        return decoded.unit

    def _check_one_transmitter(self, gauge_id: str) -> None:
        """With no channel set, the receiver must carry one transmitter only: with two,
        a frame cannot be vouched for as this gauge's (it may be another leg's)."""
        if self.channel is not None:
            return
        if self._heard is None:
            self._heard = gauge_id
        elif gauge_id != self._heard and self._second is None:
            self._second = gauge_id
        if self._second is not None:  # for good: neither one is known to be this gauge's
            raise DriverError(f"frames from transmitters {self._heard} and {self._second} "
                              "reach this receiver and the gauge has no channel: set its "
                              "channel (CC or GGCC) to the transmitter fitted to this gauge",
                              where=self.where)

    def _is_mine(self, gauge_id: str) -> bool:
        return same_indicator(self.channel, gauge_id)
