"""32-bit word order, signedness and scaling of the profile codec."""

from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st

from ogacq_drivers.axes.profile import (
    counts_to_mm,
    int_to_words,
    load_profile,
    mm_to_counts,
    words_to_int,
)

IAI = load_profile("iai-pcon")
CIA = load_profile("cia402")


@pytest.mark.parametrize(
    ("value", "order", "signed", "words"),
    [
        (0x12345678, "high_first", False, [0x1234, 0x5678]),
        (0x12345678, "low_first", False, [0x5678, 0x1234]),
        (-1, "high_first", True, [0xFFFF, 0xFFFF]),
        (-2, "low_first", True, [0xFFFE, 0xFFFF]),
        (-(1 << 31), "high_first", True, [0x8000, 0x0000]),
        (6000, "high_first", True, [0x0000, 0x1770]),  # IAI 60.00 mm
        (-584, "low_first", True, [0xFDB8, 0xFFFF]),  # CiA -5.84 mm at 100 counts/mm
    ],
)
def test_known_vectors(value: int, order: str, signed: bool, words: list[int]) -> None:
    assert int_to_words(value, 2, word_order=order, signed=signed) == words  # type: ignore[arg-type]
    assert words_to_int(words, word_order=order, signed=signed) == value  # type: ignore[arg-type]


@given(
    st.integers(min_value=-(1 << 31), max_value=(1 << 31) - 1),
    st.sampled_from(["high_first", "low_first"]),
)
def test_signed_32_round_trip(value: int, order: str) -> None:
    words = int_to_words(value, 2, word_order=order, signed=True)  # type: ignore[arg-type]
    assert all(0 <= w <= 0xFFFF for w in words)
    assert words_to_int(words, word_order=order, signed=True) == value  # type: ignore[arg-type]


@given(st.integers(min_value=0, max_value=(1 << 32) - 1))
def test_word_orders_are_mirror_images(value: int) -> None:
    high = int_to_words(value, 2, word_order="high_first", signed=False)
    low = int_to_words(value, 2, word_order="low_first", signed=False)
    assert high == low[::-1]


@given(st.integers(min_value=-(1 << 15), max_value=(1 << 15) - 1))
def test_signed_16_round_trip(value: int) -> None:
    words = int_to_words(value, 1, word_order="high_first", signed=True)
    assert words_to_int(words, word_order="low_first", signed=True) == value


def test_out_of_range_is_refused() -> None:
    with pytest.raises(ValueError, match="does not fit the signed 32-bit range"):
        int_to_words(1 << 31, 2, word_order="high_first", signed=True)
    with pytest.raises(ValueError, match="does not fit the unsigned 16-bit range"):
        int_to_words(-1, 1, word_order="high_first", signed=False)
    with pytest.raises(ValueError, match="not a 16-bit word"):
        words_to_int([0x10000, 0], word_order="high_first", signed=False)


@given(
    st.floats(min_value=-100_000.0, max_value=100_000.0, allow_nan=False),
    st.sampled_from([IAI, CIA]),
)
def test_position_round_trip_within_half_a_count(value_mm: float, profile) -> None:  # type: ignore[no-untyped-def]
    registers = profile.encode("position_actual", value_mm)
    back = profile.decode("position_actual", registers)
    assert abs(back - value_mm) <= 0.5 / profile.codec.counts_per_mm + 1e-9


def test_profile_word_orders_differ_on_the_wire() -> None:
    assert IAI.encode("position_actual", -5.84) == [0xFFFF, 0xFDB8]
    assert CIA.encode("position_actual", -5.84) == [0xFDB8, 0xFFFF]
    assert CIA.encode("profile_velocity", 100.0) == [10000, 0]
    assert IAI.encode("servo_on_command", True) is True
    with pytest.raises(TypeError, match="coil"):
        IAI.encode("servo_on_command", 1)
    with pytest.raises(ValueError, match="integer"):
        CIA.encode("controlword", 1.5)


def test_scaling_helpers() -> None:
    assert mm_to_counts(0.005, 100.0) in (0, 1)
    assert mm_to_counts(-5.84, 100.0) == -584
    assert counts_to_mm(-584, 100.0) == pytest.approx(-5.84)
    with pytest.raises(ValueError, match="cannot convert"):
        mm_to_counts(float("nan"), 100.0)
