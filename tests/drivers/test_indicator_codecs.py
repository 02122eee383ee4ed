"""Indicator codecs against the exact frames of INSTRUMENTS.md."""

from __future__ import annotations

from decimal import Decimal

import pytest

from ogacq_drivers.errors import DeviceBusy, DeviceFault, FrameError, UnitError
from ogacq_drivers.indicators import base, digimatic, mitutoyo_01a, sylvac, uwave
from ogacq_drivers.indicators.backend import Decoded

# ---------------------------------------------------------------------- 01A


@pytest.mark.parametrize(
    ("frame", "channel", "value", "decimals"),
    [
        (b"01A+0000.123\r", "1", Decimal("0.123"), 3),  # mm, 0.001
        (b"01A+000.1234\r", "1", Decimal("0.1234"), 4),  # inch
        (b"01A-001.2340\r", "1", Decimal("-1.2340"), 4),
        (b"02A-0012.345\r", "2", Decimal("-12.345"), 3),  # multiplexer channel 2
        (b"0CA+0000.500\r", "C", Decimal("0.5"), 3),  # letters on larger boxes
        (b"01A-0000.000\r", "1", Decimal("0"), 3),
    ],
)
def test_01a_decodes_the_spec_frames(frame: bytes, channel: str, value: Decimal, decimals: int):
    reply = mitutoyo_01a.decode_reply(frame)
    assert reply == Decoded(value=value, decimals=decimals, unit=None, channel=channel)


@pytest.mark.parametrize(
    ("value", "decimals", "channel", "frame"),
    [
        (0.123, 3, "1", b"01A+0000.123\r"),
        (Decimal("0.1234"), 4, "1", b"01A+000.1234\r"),
        (-1.234, 4, "1", b"01A-001.2340\r"),
        (-0.0001, 3, "2", b"02A+0000.000\r"),  # rounds to zero: no "-0"
    ],
)
def test_01a_encodes_the_spec_frames(value, decimals: int, channel: str, frame: bytes):
    assert mitutoyo_01a.encode_reply(value, decimals=decimals, channel=channel) == frame
    assert mitutoyo_01a.encode_request(channel) == channel.encode() + b"\r"


def test_01a_error_frames_are_classified_before_any_number():
    with pytest.raises(DeviceFault) as fault:
        mitutoyo_01a.decode_reply(b"911\r", where="gauge A")
    assert not isinstance(fault.value, DeviceBusy)
    assert fault.value.code == "911"
    assert "gauge A" in str(fault.value) and "no data" in str(fault.value)

    with pytest.raises(DeviceBusy) as busy:
        mitutoyo_01a.decode_reply(b"918\r", where="gauge A")
    assert busy.value.code == "918"

    with pytest.raises(DeviceFault) as other:
        mitutoyo_01a.decode_reply(b"915\r")
    assert other.value.code == "915"


@pytest.mark.parametrize(
    "frame",
    [
        b"01A+0000.123",  # no terminator
        b"01A+000.123\r",  # a digit short
        b"01A+00000.123\r",  # a digit long
        b"01A+00000123\r",  # no decimal point
        b"01A+00.0.123\r",  # two points
        b"01A 0000.123\r",  # no sign
        b"01B+0000.123\r",  # wrong item
        b"11A+0000.123\r",  # wrong code
        b"01A+0000123.\r",  # point last
        b"01A+.0000123\r",  # point first
        b"91\r",
        b"9110\r",
        b"",
    ],
)
def test_01a_rejects_frames_off_the_grammar(frame: bytes):
    with pytest.raises(FrameError) as error:
        mitutoyo_01a.decode_reply(frame, where="gauge A")
    assert "gauge A" in str(error.value)


def test_01a_encoders_refuse_what_does_not_fit():
    with pytest.raises(ValueError):
        mitutoyo_01a.encode_reply(123456.0, decimals=3)
    with pytest.raises(ValueError):
        mitutoyo_01a.encode_request("12")
    with pytest.raises(ValueError):
        mitutoyo_01a.encode_error("921")
    assert mitutoyo_01a.encode_error("918") == b"918\r"


# ---------------------------------------------------------------- Digimatic


@pytest.mark.parametrize(
    ("frame", "value", "decimals", "unit", "nibble"),
    [
        # An earlier INSTRUMENTS.md said "FFFF000012330 = +1.233 mm"; by its own nibble
        # table and Mitutoyo's QM-Height manual 99MAF600B, 6.2.1 ("normal measurement
        # of 0.123 mm") the digits d6-d11 are 000123 and d12 = 3: +0.123 mm.
        (b"FFFF000012330\r\n", Decimal("0.123"), 3, "mm", "0"),
        (b"FFFF000123330\r\n", Decimal("1.233"), 3, "mm", "0"),  # what +1.233 mm looks like
        (b"FFFF021076540\r\n", Decimal("21.0765"), 4, "mm", "0"),  # maker's example
        (b"FFFF801234530\r\n", Decimal("-12.345"), 3, "mm", "0"),  # projector manual example
        (b"FFFF000485551\r\n", Decimal("0.04855"), 5, "inch", "1"),
        (b"FFFF000485558\r\n", Decimal("0.04855"), 5, "inch", "8"),  # bit-reversed inch
        (b"FFFF000123330\r", Decimal("1.233"), 3, "mm", "0"),  # CR only
        (b"FFFF000123330\n", Decimal("1.233"), 3, "mm", "0"),  # LF only
        (b"FFFF012345600\r\n", Decimal("123456"), 0, "mm", "0"),
    ],
)
def test_digimatic_decodes_the_spec_frames(frame, value, decimals, unit, nibble):
    decoded = digimatic.decode_frame(frame)
    assert decoded == digimatic.DigimaticFrame(
        value=value, decimals=decimals, unit=unit, unit_nibble=nibble
    )


@pytest.mark.parametrize(
    ("frame", "value", "unit"),
    [
        # QM-Height manual 99MAF600B, 6.2.1 "Digimatic 2 output": "8 F 0 0 + 0 0 0 1 2 3
        # 3 mm" at a normal measurement of 0.123 mm.
        (b"8F00000012330\r\n", Decimal("0.123"), "mm"),
        # Built from the same layout: d3-d4 carry the two high digits, then the six.
        (b"8F12834567830\r\n", Decimal("-12345.678"), "mm"),
        (b"8F00000485551\r\n", Decimal("0.04855"), "inch"),
    ],
)
def test_digimatic2_frames(frame: bytes, value: Decimal, unit: str):
    decoded = digimatic.decode_frame(frame)
    assert (decoded.value, decoded.unit, decoded.digimatic2) == (value, unit, True)
    encoded = digimatic.encode_frame(
        value, decimals=decoded.decimals, unit=decoded.unit, digimatic2=True
    )
    assert encoded == frame


def test_digimatic2_refuses_what_does_not_fit_or_spell():
    with pytest.raises(ValueError):
        digimatic.encode_frame(1000000.0, decimals=3, digimatic2=True)  # nine digits
    for frame in (b"8E00000012330\r\n", b"8F0A000012330\r\n", b"1F00000012330\r\n"):
        with pytest.raises(FrameError):
            digimatic.decode_frame(frame)


def test_digimatic_spec_examples_in_mm():
    assert base.to_mm(digimatic.decode_frame(b"FFFF000012330\r\n").value, "mm") == 0.123
    assert base.to_mm(digimatic.decode_frame(b"FFFF000123330\r\n").value, "mm") == 1.233
    assert base.to_mm(digimatic.decode_frame(b"FFFF021076540\r\n").value, "mm") == 21.0765
    inch = digimatic.decode_frame(b"FFFF000500041\r\n")
    assert base.to_mm(inch.value, inch.unit) == pytest.approx(12.7, abs=1e-12)


def test_digimatic_encodes_the_spec_frames():
    assert digimatic.encode_frame(0.123, decimals=3) == b"FFFF000012330\r\n"
    assert digimatic.encode_frame(1.233, decimals=3) == b"FFFF000123330\r\n"
    assert digimatic.encode_frame(Decimal("21.0765"), decimals=4) == b"FFFF021076540\r\n"
    assert digimatic.encode_frame(-12.345, decimals=3) == b"FFFF801234530\r\n"
    assert (
        digimatic.encode_frame(0.04855, decimals=5, unit="inch", inch_nibble="8")
        == b"FFFF000485558\r\n"
    )
    with pytest.raises(ValueError):
        digimatic.encode_frame(1000.0, decimals=4)  # needs seven digits


@pytest.mark.parametrize(
    "frame",
    [
        b"FFFF000012330",  # no terminator
        b"FFFF00001233\r\n",  # 12 nibbles
        b"FFFF0000123300\r\n",  # 14 nibbles
        b"FFFF0000A2330\r\n",  # not BCD
        b"FFFF100012330\r\n",  # sign nibble 1
        b"FFFF000012360\r\n",  # decimal position 6
        b"FFFF000012332\r\n",  # unit nibble 2
        b"FFFE000012330\r\n",  # header
        b"FFFF 0 012330\r\n",  # spaces as in the manual's typesetting
    ],
)
def test_digimatic_rejects_frames_off_the_grammar(frame: bytes):
    with pytest.raises(FrameError):
        digimatic.decode_frame(frame)


# ------------------------------------------------------------------- U-WAVE


def test_uwave_decodes_the_spec_frame():
    decoded = uwave.decode_frame(b"DT10000+00000011.88M\r")
    assert decoded == uwave.UWaveData(
        group="00", channel="00", value=Decimal("11.88"), decimals=2, unit="mm"
    )
    assert decoded.gauge_id == "0000"
    assert uwave.encode_data(11.88, decimals=2) == b"DT10000+00000011.88M\r"


def test_uwave_inch_and_channels():
    decoded = uwave.decode_frame(b"DT10103-00000.04855I\r")
    assert isinstance(decoded, uwave.UWaveData)
    assert (decoded.group, decoded.channel, decoded.unit) == ("01", "03", "inch")
    assert base.to_mm(decoded.value, decoded.unit) == pytest.approx(-1.23317, abs=1e-9)


@pytest.mark.parametrize(
    ("code", "warning", "words"),
    [  # every code of the U-WAVE-R manual 99MAL216A, section 6.1
        ("00", True, "battery"),
        ("01", False, "not responding"),
        ("02", False, "status 02"),
        ("03", False, "data loss"),
        ("04", False, "disconnected"),
        ("05", False, "no data"),
        ("50", False, "status 50"),
        ("51", False, "status 51"),
        ("99", False, "error 99"),
        ("07", False, "unknown"),
    ],
)
def test_uwave_status_frames_are_classified(code: str, warning: bool, words: str):
    frame = uwave.encode_status(code, gauge_id="0102")
    assert len(frame) == 19 + 1  # 19 characters and CR (99MAL216A 6.1)
    decoded = uwave.decode_frame(frame)
    assert isinstance(decoded, uwave.UWaveStatus)
    assert decoded.code == code and decoded.gauge_id == "0102"
    assert decoded.is_warning is warning
    assert words in decoded.meaning


@pytest.mark.parametrize(
    ("frame", "gauge_id", "ident", "code"),
    [  # the layout of 99MAL216A 6.1: ST1 GG CC <10-digit id or FFFFFFFFFF> SS
        (b"ST10102FFFFFFFFFF04\r", "0102", "FFFFFFFFFF", "04"),  # disconnected, id unknown
        (b"ST100001234567890" b"00\r", "0000", "1234567890", "00"),  # battery low, known id
        (b"ST10301000000004299\r", "0301", "0000000042", "99"),
    ],
)
def test_uwave_status_frames_of_the_manual(frame: bytes, gauge_id: str, ident: str, code: str):
    decoded = uwave.decode_frame(frame)
    assert isinstance(decoded, uwave.UWaveStatus)
    assert (decoded.gauge_id, decoded.transmitter_id, decoded.code) == (gauge_id, ident, code)
    assert uwave.encode_status(code, gauge_id=gauge_id, transmitter_id=ident) == frame


def test_uwave_unit_zero_means_no_unit():
    decoded = uwave.decode_frame(b"DT10000+00000011.880\r")  # unit character "0" (99MAL216A 6.1)
    assert isinstance(decoded, uwave.UWaveData)
    assert (decoded.value, decoded.decimals, decoded.unit) == (Decimal("11.88"), 2, None)
    assert uwave.encode_data(11.88, decimals=2, unit=None) == b"DT10000+00000011.880\r"


@pytest.mark.parametrize(
    "frame",
    [
        b"DT10000+00000011.88M",  # no terminator
        b"DT10000+0000011.88M\r",  # a digit short (fixed width)
        b"DT10000+00000011.88X\r",  # unit letter
        b"DT10000 00000011.88M\r",  # sign
        b"DT1000+000000011.88M\r",  # channel short
        b"DT10000+0000001.1.8M\r",  # two points
        b"DT20000+00000011.88M\r",
        b"ST10001\r",
        b"ST1000104\r",  # INSTRUMENTS.md's short shape: no transmitter id
        b"ST10001..04\r",
        b"ST10001FFFFFFFFF04\r",  # id one character short
        b"ST10001FFFFFFFFFFF04\r",  # id one character long
        b"ST10001ABCDEF012304\r",  # id neither digits nor all F
    ],
)
def test_uwave_rejects_frames_off_the_grammar(frame: bytes):
    with pytest.raises(FrameError):
        uwave.decode_frame(frame)


# ------------------------------------------------------------------- Sylvac


@pytest.mark.parametrize(
    ("frame", "value", "decimals", "flag"),
    [
        (b"+12.345\r", Decimal("12.345"), 3, ""),
        (b"-0.005\r", Decimal("-0.005"), 3, ""),
        (b" 0.000\r", Decimal("0.000"), 3, ""),  # space sign
        (b"+0.04855\r", Decimal("0.04855"), 5, ""),  # inch, .00005
        (b"+1.234>\r", Decimal("1.234"), 3, ">"),  # tolerance mode
    ],
)
def test_sylvac_decodes_replies(frame: bytes, value: Decimal, decimals: int, flag: str):
    assert sylvac.decode_reply(frame) == sylvac.SylvacReply(
        value=value, decimals=decimals, tolerance_flag=flag
    )


@pytest.mark.parametrize("code", ["0", "1", "2", "3"])
def test_sylvac_errors_are_classified(code: str):
    with pytest.raises(DeviceFault) as fault:
        sylvac.decode_reply(f"ERR{code}\r".encode(), where="gauge S")
    assert fault.value.code == f"ERR{code}"
    assert "gauge S" in str(fault.value)
    assert sylvac.ERROR_MEANINGS[code] in str(fault.value)


@pytest.mark.parametrize(
    ("frame", "ident"),
    [  # Opto-RS manual, "Identification": "SY" instrument "." OPT1 {"." OPT2} CR
        (b"SY235.1\r", "SY235.1"),
        (b"SY203.1.2\r", "SY203.1.2"),
        (b"+1.233\r", None),
        (b"SY235\r", None),  # no option field
        (b"SY.1\r", None),
    ],
)
def test_sylvac_identification_line(frame: bytes, ident: str | None):
    assert sylvac.decode_identification(frame) == ident
    if ident is not None:
        with pytest.raises(FrameError):
            sylvac.decode_reply(frame)  # not a value: the driver skips it before decoding
        assert sylvac.encode_identification(*ident[2:].split(".")) == frame


def test_sylvac_encodes_replies():
    assert sylvac.encode_reply(12.345, decimals=3) == b"+12.345\r"
    assert sylvac.encode_reply(-0.005, decimals=3) == b"-0.005\r"
    assert sylvac.encode_error(3) == b"ERR3\r"
    assert sylvac.encode_error("ERR0") == b"ERR0\r"
    assert sylvac.UNIT_COMMANDS == {"mm": b"MM\r", "inch": b"IN\r"}


@pytest.mark.parametrize(
    "frame", [b"+12.345", b"12.345\r", b"+12\r", b"+.345\r", b"+12.345mm\r", b"ERR\r", b"?\r"]
)
def test_sylvac_rejects_frames_off_the_grammar(frame: bytes):
    with pytest.raises(FrameError):
        sylvac.decode_reply(frame)


# -------------------------------------------------------------------- units


def test_default_decimal_layouts_of_mm_and_inch_do_not_overlap():
    assert not base.DEFAULT_DECIMALS["mm"] & base.DEFAULT_DECIMALS["inch"]


def test_an_inch_layout_is_refused_when_configured_mm():
    accepted = base.accepted_decimals("mm", None, where="g")
    base.check_decimals(3, "mm", accepted, where="g", frame=b"01A+0000.123\r")
    with pytest.raises(UnitError) as error:
        base.check_decimals(4, "mm", accepted, where="gauge A", frame=b"01A+000.1234\r")
    assert "gauge A" in str(error.value) and "inch" in str(error.value)


def test_configured_unit_must_be_mm_or_inch():
    assert base.check_unit("inch", where="g") == "inch"
    for bad in ("in", "MM", "", None, "µm"):
        with pytest.raises(UnitError):
            base.check_unit(bad, where="g")


def test_to_mm_is_exact_and_has_no_negative_zero():
    assert base.to_mm(Decimal("0.1234"), "inch") == 3.13436
    assert base.to_mm(Decimal("-0.000"), "mm") == 0.0
    assert str(base.to_mm(Decimal("-0.000"), "mm")) == "0.0"
