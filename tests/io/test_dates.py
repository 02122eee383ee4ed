"""The one rule for dates (ogacq/io/dates.py): what it takes, what it refuses and
how it says so, strictly for what a person gave and leniently for what ogacq
recorded; and the campaign file, the demo's --date and the wizard reading dates
by it."""

from __future__ import annotations

import datetime

import pytest

from ogacq.io.dates import (
    DateError,
    date_or_none,
    moment_or_none,
    parse_date,
    parse_moment,
    wall_time,
)

PLUS_ONE = datetime.timezone(datetime.timedelta(hours=1))


@pytest.mark.parametrize(("text", "zone", "expected"), [
    ("2026-01-10", False, datetime.datetime(2026, 1, 10)),
    ("2026-01-10T09:00", False, datetime.datetime(2026, 1, 10, 9)),
    ("2026-01-10 09:00:05.25", False, datetime.datetime(2026, 1, 10, 9, 0, 5, 250000)),
    ("2024-02-29T23:59:59", False, datetime.datetime(2024, 2, 29, 23, 59, 59)),
    ("2026-01-10T09:00:00+01:00", True, datetime.datetime(2026, 1, 10, 9, tzinfo=PLUS_ONE)),
    ("2026-01-10T09:00:00+0100", True, datetime.datetime(2026, 1, 10, 9, tzinfo=PLUS_ONE)),
    ("2026-01-10T08:00:00Z", True, datetime.datetime(2026, 1, 10, 8, tzinfo=datetime.UTC)),
])
def test_moments_the_rule_takes(text, zone, expected):
    assert parse_moment(text, source="c.toml", key="date", zone=zone) == expected


@pytest.mark.parametrize(("text", "zone", "why"), [
    ("2026-02-30", True, "day is out of range for month"),
    ("2025-02-29T09:00", True, "day is out of range for month"),
    ("2026-01-10T24:00", True, "hour must be in 0..23"),
    ("2026-01-10T09:00:60", True, "second must be in 0..59"),
    ("20260110", True, "it does not start with YYYY-MM-DD"),  # fromisoformat takes these
    ("2026-W02-6", True, "it does not start with YYYY-MM-DD"),
    ("2026-01-10T9:00", True, "'T9:00' after the day is not a time of day"),
    ("2026-01-10+01:00", True, "a UTC offset without a time of day"),
    ("２０２６-01-10", True, "it does not start with YYYY-MM-DD"),  # ASCII digits only
    ("", True, "it is empty"),
    ("2026-01-10T09:00:00+01:00", False, "it carries a UTC offset"),
    ("2026-01-10T09:00:00Z", False, "it carries a UTC offset"),
])
def test_moments_the_rule_refuses_in_one_form(text, zone, why):
    with pytest.raises(DateError) as caught:
        parse_moment(text, source="c.toml", key="simulator.date", zone=zone, line=6)
    assert str(caught.value).startswith(
        f"c.toml:6: simulator.date = {text!r} is not a date and time: {why}")
    assert ("the shop's local time without a UTC offset" in str(caught.value)) is not zone
    assert caught.value.exit_code == 2  # an InputError


def test_a_date_is_a_day_and_nothing_after_it():
    assert parse_date(" 2027-03-01 ", source=None, key="due") == datetime.date(2027, 3, 1)
    with pytest.raises(DateError, match=r"^due = '2026-02-30' is not a date: day is out of "
                                        r"range for month \(a date is YYYY-MM-DD\)$"):
        parse_date("2026-02-30", source=None, key="due")
    with pytest.raises(DateError, match="'T10:00' follows the day"):
        parse_date("2027-03-01T10:00", source=None, key="due")
    with pytest.raises(DateError, match="'garbage' follows the day"):
        parse_date("2027-03-01garbage", source=None, key="due")


def test_recorded_values_that_break_the_rule_are_unknown_not_fatal():
    assert date_or_none("2027-03-01") == datetime.date(2027, 3, 1)
    assert date_or_none(datetime.datetime(2027, 3, 1, 9)) == datetime.date(2027, 3, 1)
    for bad in ("2027-03-01garbage", "2026-02-30", "01/03/2027", 20270301, None):
        assert date_or_none(bad) is None
    assert moment_or_none(datetime.date(2026, 1, 10)) == datetime.datetime(2026, 1, 10)
    assert moment_or_none("2026-01-10T09:00:00+0100") == \
        datetime.datetime(2026, 1, 10, 9, tzinfo=PLUS_ONE)
    assert moment_or_none("2026-01-10T25:00") is None and moment_or_none(1.5) is None
    # on one machine's axis: the wall clock as stated, the offset dropped
    assert wall_time("2026-01-10T09:00:00+01:00") == datetime.datetime(2026, 1, 10, 9)


def _campaign(tmp_path, line: str) -> str:
    from ogacq.campaign.campaign_file import read_campaign
    from ogacq.errors import InputError
    from tests.record.test_identity_files import CAMPAIGN, IDENTIFIED

    (tmp_path / "machine.toml").write_text(IDENTIFIED)
    old = "due = 2027-03-01" if line.startswith("due") else "date = 2026-01-10T09:00:00"
    path = tmp_path / "c.toml"
    path.write_text(CAMPAIGN.replace(old, line))
    with pytest.raises(InputError) as caught:
        read_campaign(path)
    return str(caught.value).removeprefix(f"{path}:")


@pytest.mark.parametrize(("line", "said"), [
    # tomllib says "Invalid date or datetime" / "Expected newline": the rule says why
    ("due = 2026-02-30", "20: due = '2026-02-30' is not a date: day is out of range for "
                         "month (a date is YYYY-MM-DD)"),
    ("date = 2026-01-10T25:00:00", "6: date = '2026-01-10T25:00:00' is not a date and time: "
                                   "hour must be in 0..23"),
    ("date = 2026-01-10T09:00", "6: date = '2026-01-10T09:00' is not a TOML date: TOML needs "
                                "the seconds"),
    # valid TOML, but a rehearsed campaign's date is the shop's wall time
    ("date = 2026-01-10T09:00:00+01:00", "6: simulator.date = '2026-01-10T09:00:00+01:00' is "
                                         "not a date and time: it carries a UTC offset"),
])
def test_a_campaign_files_bad_date_names_line_key_and_value(tmp_path, line, said):
    assert _campaign(tmp_path, line).startswith(said)


def test_the_wizard_asks_again_with_the_rules_words():
    from ogacq.cli.wizard.traceability import _date

    assert _date("due")("") is None and _date("due")("2027-03-01") == datetime.date(2027, 3, 1)
    with pytest.raises(ValueError, match=r"^due = '2027-02-29' is not a date: day is out of "):
        _date("due")("2027-02-29")


def test_a_toml_complaint_about_something_else_is_left_as_it_was(tmp_path):
    from ogacq.errors import InputError
    from ogacq.io.toml_file import read_toml

    path = tmp_path / "f.toml"
    path.write_text("due = 2027-03-01\ndue = 2027-03-02\n")  # a key twice: not the date
    with pytest.raises(InputError) as caught:
        read_toml(path, "the file")
    assert not isinstance(caught.value, DateError) and "not valid TOML" in str(caught.value)
    path.write_text("due = 2027-03-01 # fine\nwhen = 2026-01-10T09:00:00+0100\n")
    with pytest.raises(DateError, match=r"f\.toml:2: when = '2026-01-10T09:00:00\+0100' is "
                                        r"not a TOML date: TOML needs the seconds, and a colon"):
        read_toml(path, "the file")
