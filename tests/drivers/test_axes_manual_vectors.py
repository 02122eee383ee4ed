"""The makers' own example frames, rebuilt from the shipped profiles through pymodbus's
framers (the real codec: RTU CRC, ASCII LRC, Modbus TCP header) and compared byte for
byte. The frames are typed here from the manuals, not produced by ogacq's code:

- IAI "ROBO Cylinder Serial Communication [for Modbus]" (ME0162; US edition on
  azmanual.top, manual 350346), §5.6.1 / §6.6.1 "Numerical value movement command"
  (FC 0x10 at 0x9900: PCMD s32 0.01 mm, INP s32 0.01 mm, VCMD s32 0.01 mm/s, ACMD
  0.01 G, PPOW, CTLF; 32-bit values high word first), ASCII examples 2, 4 and 7.
- Kinco "FD3 & CD3 User Manual" §12.3 (= FD5P manual §10.2.3) "MODBUS RTU":
  read status word at 0x3200, write control word at 0x3100, FC 0x10 example with a
  32-bit value LOW word first; FD5/FD5P object tables: speed in DEC =
  RPM × 512 × encoder resolution / 1875.
- Mitsubishi "MR-JE-_C Servo Amplifier Instruction Manual (Modbus/TCP)"
  (SH(NA)030269ENG), §2.3.2 usage example: unit identifier FFh, a 32-bit register
  answered low word first (5678h, then 1234h).
"""

from __future__ import annotations

import pytest
from pymodbus.framer import FramerAscii, FramerRTU, FramerSocket
from pymodbus.pdu import DecodePDU
from pymodbus.pdu.register_message import (
    ReadHoldingRegistersRequest,
    WriteMultipleRegistersRequest,
    WriteSingleRegisterRequest,
)

from ogacq_drivers.axes.profile import Profile, int_to_words, load_profile, words_to_int

IAI_MOVE_BLOCK = ("move_target", "move_band", "move_speed", "move_acceleration", "move_push",
                  "move_control")


def _rtu(request: object) -> bytes:
    return FramerRTU(DecodePDU(False)).buildFrame(request)  # type: ignore[arg-type]


def _ascii(request: object) -> bytes:
    return FramerAscii(DecodePDU(False)).buildFrame(request)  # type: ignore[arg-type]


def _registers(profile: Profile, names: tuple[str, ...], values: tuple[float, ...]) -> list[int]:
    registers: list[int] = []
    for name, value in zip(names, values, strict=True):
        encoded = profile.encode(name, value)
        assert isinstance(encoded, list)
        registers += encoded
    return registers


@pytest.mark.parametrize(("names", "values", "frame"), [
    # ME0162 §6.6.1 example 4: incremental (CTLF bit 3) pitch 10 mm, band 0.1 mm,
    # 100 mm/s, 0.3 G, push 0: all nine registers
    (IAI_MOVE_BLOCK, (10.0, 0.1, 100.0, 30, 0, 8),
     ":01109900000912000003E80000000A00002710001E00000008E9\r\n"),
    # example 2: target 50 mm, band 0.1 mm, 100 mm/s, 0.3 G (registers 9900..9906)
    (IAI_MOVE_BLOCK[:4], (50.0, 0.1, 100.0, 30),
     ":011099000007 0E0000138800000 00A00002710001E47\r\n".replace(" ", "")),
])
def test_iai_numerical_move_is_the_manuals_query(names: tuple[str, ...],
                                                  values: tuple[float, ...], frame: str) -> None:
    iai = load_profile("iai-pcon")
    request = WriteMultipleRegistersRequest(
        address=iai.value(names[0]).address, registers=_registers(iai, names, values), dev_id=1)
    assert _ascii(request) == frame.encode()


def test_iai_push_register_is_the_manuals_and_not_in_percent() -> None:
    """ME0162 example 7: PPOW 50 % is written 007Fh (a fraction of 255), CTLF 0006h
    (push, bits 1 and 2) at 9907h: the profile's push and control registers."""
    iai = load_profile("iai-pcon")
    names = ("move_push", "move_control")
    request = WriteMultipleRegistersRequest(
        address=iai.value("move_push").address, registers=_registers(iai, names, (0x7F, 6)),
        dev_id=1)
    assert _ascii(request) == b":0110990700020400 7F0006C4\r\n".replace(b" ", b"")


def test_iai_move_block_ships_absolute_positioning_and_no_push() -> None:
    """CTLF bit 3 is incremental, bits 1-2 push [ME0162 §5.6.1]: the move writes 0 to
    both push and control, so every move is an absolute positioning."""
    step = load_profile("iai-pcon").commands["move"].start[0]
    shipped = dict(zip(step.to, step.value, strict=True))
    assert shipped["move_push"] == 0 and shipped["move_control"] == 0
    assert shipped["move_acceleration"] == 30  # 0.30 G in 0.01 G


def test_kinco_status_and_control_word_are_the_manuals_frames() -> None:
    kinco = load_profile("kinco-fd")
    read = ReadHoldingRegistersRequest(address=kinco.value("statusword").address, count=2,
                                       dev_id=1)
    assert _rtu(read) == bytes.fromhex("01 03 32 00 00 02 CA B3")
    encoded = kinco.encode("controlword", 0x000F)
    assert isinstance(encoded, list)
    write = WriteSingleRegisterRequest(address=kinco.value("controlword").address,
                                       registers=encoded, dev_id=1)
    assert _rtu(write) == bytes.fromhex("01 06 31 00 00 0F C7 32")


def test_kinco_32_bit_values_go_low_word_first() -> None:
    """FD3/CD3 §12.3: 0x00085555 to "target velocity" (0x6F00) is sent 55 55 00 08."""
    kinco = load_profile("kinco-fd")
    registers = int_to_words(0x00085555, 2, word_order=kinco.codec.word_order, signed=False)
    request = WriteMultipleRegistersRequest(address=0x6F00, registers=registers, dev_id=1)
    assert _rtu(request) == bytes.fromhex("01 10 6F 00 00 02 04 55 55 00 08 1A 47")


@pytest.mark.parametrize("encoder_counts_per_rev", [10_000, 65_536])
def test_kinco_speed_is_in_dec(encoder_counts_per_rev: int) -> None:
    """DEC = RPM × 512 × R / 1875 [Kinco FD5/FD5P]; the axis makes counts_per_mm
    increments per mm, so v mm/s is v × counts_per_mm / R revolutions per second."""
    kinco = load_profile("kinco-fd")
    speed_mm_s = 20.0
    rpm = speed_mm_s * kinco.codec.counts_per_mm / encoder_counts_per_rev * 60.0
    dec = rpm * 512 * encoder_counts_per_rev / 1875
    encoded = kinco.encode("profile_velocity", speed_mm_s)
    assert isinstance(encoded, list)
    assert words_to_int(encoded, word_order="low_first", signed=False) == round(dec) == 32768


def test_mr_je_c_reads_32_bits_low_word_first_at_unit_255() -> None:
    """MR-JE-C Modbus/TCP §2.3.2 usage example: the response to a read of 2B05h..2B07h
    (4 points) carries 5678h then 1234h for the 32-bit register 2B05h."""
    response = bytes.fromhex("0001 0000 000B FF 03 08 5678 1234 1000 2000".replace(" ", ""))
    _, pdu = FramerSocket(DecodePDU(False)).handleFrame(response, 0, 0)
    assert pdu is not None and pdu.dev_id == 255
    mrjec = load_profile("mr-je-c")
    assert set(mrjec.device_ids.values()) == {255}
    assert words_to_int(pdu.registers[:2], word_order=mrjec.codec.word_order,
                        signed=False) == 0x12345678
    assert mrjec.transport.functions == (3, 8, 16)  # 03h, 08h, 10h only [§2.3.1]
