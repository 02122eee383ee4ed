"""The headline rule (JCGM 100:2008 7.2.6): U to two significant digits, the value
rounded to the same decimal place, k stated. The expected strings are written out
by hand from the rule, not computed by ogacq."""

import pytest

from ogacq.uncertainty.reporting import headline, rounded, two_digits


@pytest.mark.parametrize(("value", "U", "expected"), [
    # GUM 7.2.6's own example: y = 10.057 62 ohm with u = 27 mohm reads 10.058
    (10.05762, 0.027, "+10.058 ± 0.027 ohm (k = 2)"),
    # the demo's joint offset x: U = 0.003492905 mm
    (0.03473, 0.003492905, "+0.0347 ± 0.0035 ohm (k = 2)"),
    (-1.066434, 0.003744106, "-1.0664 ± 0.0037 ohm (k = 2)"),
    # rounding U makes a third digit: 0.00996 is 0.010, two significant digits
    (1.23456, 0.00996, "+1.235 ± 0.010 ohm (k = 2)"),
    (0.5, 0.01049, "+0.500 ± 0.010 ohm (k = 2)"),
    (0.123449, 0.0014999, "+0.1234 ± 0.0015 ohm (k = 2)"),
    # a value that rounds to zero carries no minus sign
    (-0.00001, 0.0035, "+0.0000 ± 0.0035 ohm (k = 2)"),
    # U of units, then of hundreds: the value to the units, to the tens
    (1234.0, 56.0, "+1234 ± 56 ohm (k = 2)"),
    (1234.0, 123.0, "+1230 ± 120 ohm (k = 2)"),
])
def test_two_significant_digits_and_the_value_at_the_same_place(value, U, expected):
    assert str(headline(value, U, 2.0, "ohm")) == expected


def test_what_is_not_known_is_said():
    assert str(headline(0.03473, None, None, "mm")) == "+0.0347 mm (U not evaluated)"
    assert str(headline(float("inf"), 0.1, 2.0, "mm")) == "not determined"
    assert str(headline(0.03473, 0.0035, 2.0, "mm", complete=False)) == \
        "+0.0347 ± 0.0035 mm (k = 2; budget incomplete)"
    assert str(headline(0.03473, 0.0035, 2.5, "mm")).endswith("(k = 2.5)")


def test_the_other_numbers_of_a_row():
    assert rounded(0.035512, 0.0035, sign=True) == "+0.0355"
    assert rounded(None, 0.0035) == "-"
    assert two_digits(0.001744074) == "0.0017"
    assert two_digits(7853.43) == "7900"
    assert two_digits(None) == "-"
