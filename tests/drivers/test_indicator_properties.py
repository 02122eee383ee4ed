"""Property tests: random, truncated and damaged bytes never give a wrong number.

Every decoder either raises one of the driver's own exceptions or returns the
number the bytes actually spell (checked against an independent reading of
the frame); frames that lost a byte are refused; encode -> decode is exact.
The codecs are those of the protocol table, every protocol of it included.
"""

from __future__ import annotations

from collections.abc import Callable
from decimal import Decimal

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from ogacq_drivers.errors import DeviceFault, DriverError, FrameError, UnitError
from ogacq_drivers.indicators import BACKENDS, base, codec, digimatic, mitutoyo_01a, sylvac, uwave
from ogacq_drivers.indicators.backend import Decoded

FAST = settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])

# Every protocol of the table, through its codec.
DECODERS: dict[str, Callable[..., object]] = {name: codec(name).decode for name in BACKENDS}


def _decode_or_driver_error(decoder: Callable[..., object], frame: bytes) -> object | None:
    """The decoded frame, or None when a driver exception was raised; anything else fails."""
    try:
        return decoder(frame, where="fuzz")
    except DriverError as exc:
        assert "fuzz" in str(exc)
        return None


# ------------------------------------------------------------- random bytes


@pytest.mark.parametrize("protocol", sorted(DECODERS))
@FAST
@given(data=st.binary(max_size=40))
def test_random_bytes_raise_only_driver_errors(protocol: str, data: bytes):
    _decode_or_driver_error(DECODERS[protocol], data)


@FAST
@given(frame=st.from_regex(rb"\A0[0-9A-Z]A[+\- ][0-9.]{8}\r\Z"))
def test_01a_frame_shaped_bytes_decode_to_what_they_spell(frame: bytes):
    reply = _decode_or_driver_error(mitutoyo_01a.decode_reply, frame)
    field = frame[4:12].decode()
    valid = field.count(".") == 1 and not field.startswith(".") and not field.endswith(".")
    assert (reply is not None) == (valid and frame[3:4] in (b"+", b"-"))
    if reply is not None:
        assert isinstance(reply, Decoded) and reply.unit is None
        assert float(reply.value) == float(frame[3:12].decode())


@FAST
@given(frame=st.from_regex(rb"\AFFFF[0-9A-F]{9}\r\n\Z"))
def test_digimatic_frame_shaped_bytes_decode_to_what_they_spell(frame: bytes):
    decoded = _decode_or_driver_error(digimatic.decode_frame, frame)
    nibbles = frame[:13].decode()
    valid = (
        nibbles[4] in "08"
        and nibbles[5:11].isdigit()
        and nibbles[11] in "012345"
        and nibbles[12] in "018"
    )
    assert (decoded is not None) == valid
    if decoded is not None:
        assert isinstance(decoded, digimatic.DigimaticFrame)
        expected = int(nibbles[5:11]) / 10 ** int(nibbles[11]) * (-1 if nibbles[4] == "8" else 1)
        assert float(decoded.value) == pytest.approx(expected, abs=1e-12)
        assert decoded.unit == ("mm" if nibbles[12] == "0" else "inch")


@FAST
@given(frame=st.from_regex(rb"\A(DT|ST)1[0-9]{4}[+\-][0-9.]{11}[MI]\r\Z"))
def test_uwave_frame_shaped_bytes_decode_to_what_they_spell(frame: bytes):
    decoded = _decode_or_driver_error(uwave.decode_frame, frame)
    if isinstance(decoded, uwave.UWaveData):
        assert float(decoded.value) == float(frame[7:19].decode())
        assert decoded.unit == ("mm" if frame[19:20] == b"M" else "inch")


@FAST
@given(frame=st.from_regex(rb"\A[+\- ]?[0-9.]{1,10}[<=>]?\r\Z"))
def test_sylvac_frame_shaped_bytes_decode_to_what_they_spell(frame: bytes):
    decoded = _decode_or_driver_error(sylvac.decode_reply, frame)
    if decoded is not None:
        assert isinstance(decoded, sylvac.SylvacReply)
        text = frame.decode().rstrip("\r<=>").replace(" ", "+")
        assert float(decoded.value) == float(text)


# --------------------------------------------------------------- round trip


# A value as (integer of display steps, decimals): exactly representable.
def _steps(max_digits: int) -> st.SearchStrategy[int]:
    return st.integers(min_value=-(10**max_digits) + 1, max_value=10**max_digits - 1)


@FAST
@given(steps=_steps(7), decimals=st.integers(1, 6), channel=st.sampled_from("123456789ABC"))
def test_01a_round_trip(steps: int, decimals: int, channel: str):
    value = Decimal(steps).scaleb(-decimals)
    try:
        frame = mitutoyo_01a.encode_reply(value, decimals=decimals, channel=channel)
    except ValueError:
        return  # does not fit the 8-character field: the encoder says so
    reply = mitutoyo_01a.decode_reply(frame)
    assert (reply.value, reply.decimals, reply.channel) == (value, decimals, channel)
    assert len(frame) == 13


@FAST
@given(steps=_steps(6), decimals=st.integers(0, 5), unit=st.sampled_from(["mm", "inch"]))
def test_digimatic_round_trip(steps: int, decimals: int, unit: str):
    value = Decimal(steps).scaleb(-decimals)
    for nibble in ("1", "8"):
        frame = digimatic.encode_frame(value, decimals=decimals, unit=unit, inch_nibble=nibble)
        decoded = digimatic.decode_frame(frame)
        assert (decoded.value, decoded.decimals, decoded.unit) == (value, decimals, unit)


@FAST
@given(
    steps=_steps(9),
    decimals=st.integers(0, 6),
    unit=st.sampled_from(["mm", "inch"]),
    gauge_id=st.from_regex(r"\A[0-9]{4}\Z"),
)
def test_uwave_round_trip(steps: int, decimals: int, unit: str, gauge_id: str):
    value = Decimal(steps).scaleb(-decimals)
    frame = uwave.encode_data(value, decimals=decimals, unit=unit, gauge_id=gauge_id)
    decoded = uwave.decode_frame(frame)
    assert isinstance(decoded, uwave.UWaveData)
    assert (decoded.value, decoded.decimals, decoded.unit, decoded.gauge_id) == (
        value,
        decimals,
        unit,
        gauge_id,
    )


@FAST
@given(steps=_steps(8), decimals=st.integers(1, 5))
def test_sylvac_round_trip(steps: int, decimals: int):
    value = Decimal(steps).scaleb(-decimals)
    decoded = sylvac.decode_reply(sylvac.encode_reply(value, decimals=decimals))
    assert (decoded.value, decoded.decimals) == (value, decimals)


@FAST
@given(value_mm=st.floats(min_value=-999.0, max_value=999.0), decimals=st.integers(1, 4))
def test_float_values_round_to_the_nearest_display_step(value_mm: float, decimals: int):
    reply = mitutoyo_01a.decode_reply(mitutoyo_01a.encode_reply(value_mm, decimals=decimals))
    assert abs(float(reply.value) - value_mm) <= 0.5 * 10**-decimals + 1e-12


@pytest.mark.parametrize("protocol", sorted(BACKENDS))
@FAST
@given(steps=_steps(5), decimals=st.integers(1, 3), unit=st.sampled_from(base.UNITS))
def test_every_codec_of_the_table_round_trips(protocol: str, steps: int, decimals: int,
                                              unit: base.Unit):
    value = Decimal(steps).scaleb(-decimals)
    frame = codec(protocol).encode(value, decimals=decimals, unit=unit)
    decoded = codec(protocol).decode(frame)
    assert (decoded.value, decoded.decimals, decoded.unit in (unit, None)) == (
        value, decimals, True)


# ------------------------------------------------------- truncated / damaged


def _encoded(protocol: str, steps: int, decimals: int,
             unit: base.Unit) -> tuple[str, bytes] | None:
    """A value frame of the protocol's codec; None where the value does not fit it."""
    try:
        return protocol, codec(protocol).encode(Decimal(steps).scaleb(-decimals),
                                                decimals=decimals, unit=unit)
    except ValueError:
        return None


def _valid_frames(protocols: list[str]) -> st.SearchStrategy[tuple[str, bytes]]:
    value_frames = st.builds(_encoded, st.sampled_from(protocols), _steps(6),
                             st.integers(0, 5), st.sampled_from(base.UNITS))
    return st.one_of(
        value_frames.filter(lambda case: case is not None),  # type: ignore[arg-type]
        st.builds(lambda c: ("uwave", uwave.encode_status(c)), st.from_regex(r"\A[0-9]{2}\Z")),
    )


@FAST
@given(case=_valid_frames(sorted(BACKENDS)), data=st.data())
def test_truncated_frames_are_refused(case: tuple[str, bytes], data: st.DataObject):
    protocol, frame = case
    cut = data.draw(st.integers(0, len(frame) - 1), label="cut")
    try:
        decoded = DECODERS[protocol](frame[:cut])
    except FrameError:
        return
    # Only the LF of a Digimatic CR LF can go without changing anything.
    assert frame[cut:] == b"\n" and decoded == DECODERS[protocol](frame)


FIXED_WIDTH = sorted(name for name in BACKENDS if codec(name).fixed_width)


@FAST
@given(case=_valid_frames(FIXED_WIDTH), data=st.data())
def test_frames_that_lost_a_byte_are_refused(case: tuple[str, bytes], data: st.DataObject):
    """Fixed-width frames (01A, Digimatic, U-WAVE, USB-ITN): any lost byte breaks the
    grammar.

    (A damaged U-WAVE status frame may still read as a status: it carries no
    number, and every status but battery-low stops the reading anyway.)
    """
    protocol, frame = case
    if frame.endswith(b"\r\n"):
        frame = frame[:-1]  # keep one terminator: losing one of CR LF is harmless
    index = data.draw(st.integers(0, len(frame) - 1), label="lost byte")
    damaged = frame[:index] + frame[index + 1 :]
    try:
        decoded = DECODERS[protocol](damaged)
    except FrameError:
        return
    except DeviceFault:
        assert frame.startswith(b"ST1"), f"{damaged!r} read as a device error"
        return
    pytest.fail(f"{damaged!r} decoded to {decoded!r}")


@FAST
@given(steps=_steps(6), unit=st.sampled_from(["mm", "inch"]), data=st.data())
def test_sylvac_frames_that_lost_a_byte_outside_the_integer_part_are_refused(
    steps: int, unit: str, data: st.DataObject
):
    """Sylvac replies have no fixed width: the pinned decimal count is the guard
    for the fractional part (a lost integer digit is undetectable, see sylvac.py)."""
    decimals = sylvac.DEFAULT_DECIMALS[unit]
    frame = sylvac.encode_reply(Decimal(steps).scaleb(-decimals), decimals=decimals)
    point = frame.index(b".")
    index = data.draw(st.sampled_from([0, *range(point, len(frame))]), label="lost byte")
    damaged = frame[:index] + frame[index + 1 :]
    accepted = base.accepted_decimals(unit, decimals, where="fuzz")
    with pytest.raises((FrameError, UnitError)):
        reply = sylvac.decode_reply(damaged, where="fuzz")
        base.check_decimals(reply.decimals, unit, accepted, where="fuzz", frame=damaged)
