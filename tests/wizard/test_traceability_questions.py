"""The wizard's traceability questions as typed at its prompts, and the inventory
of gauges met before: a gauge's certificate is typed once, then offered by serial."""

from __future__ import annotations

import datetime
import io
from dataclasses import replace

import pytest
from rich.console import Console

from ogacq.campaign.inventory import KnownGauge, load_inventory
from ogacq.cli.wizard.traceability import (
    Indicator,
    TraceabilityQuestions,
    _positive,
    temperature,
)
from ogacq.cli.wizard.ui import Screen
from ogacq.errors import InputError
from ogacq.model.machine import PAPER_PROTOTYPE

MACHINE = replace(PAPER_PROTOTYPE, serial="OG-17")
ON = datetime.date(2026, 1, 10)


def ask(monkeypatch, home, answers: list[str], indicators) -> tuple[object, str]:
    """The questions asked with ``answers`` typed, one per prompt."""
    monkeypatch.setenv("OGACQ_HOME", str(home))
    monkeypatch.setattr("sys.stdin", io.StringIO("".join(a + "\n" for a in answers)))
    shown = io.StringIO()
    questions = TraceabilityQuestions(Screen(Console(file=shown, width=120)), load_inventory())
    trace = questions.ask(MACHINE, indicators, ON)
    return trace, shown.getvalue()


def test_a_new_gauge_is_remembered_and_offered_next_time(tmp_path, monkeypatch):
    indicators = [Indicator("gauge y_x (/dev/ttyUSB0)", ("y_x",)),
                  Indicator("the indicator on /dev/ttyUSB1 (gauges z_x, z_y)", ("z_x", "z_y"))]
    trace, _ = ask(monkeypatch, tmp_path, [
        "A. Technician", "20,4",
        "SN9", "Sylvac", "S_Dial Work", "C-2025-118", "2025-06-01", "2026-06-01", "0.002", "",
        "",  # right as typed
        ""], indicators)  # the second indicator: not recorded
    assert trace.operator == "A. Technician" and trace.ambient_start_c == 20.4
    assert trace.machine.serial == "OG-17"  # the file says it: not asked
    (y_x, z_x, z_y) = sorted(trace.instruments(0.001), key=lambda i: i.gauge != "y_x")
    assert (y_x.serial, y_x.make, y_x.due, y_x.uncertainty_k) == (
        "SN9", "Sylvac", datetime.date(2026, 6, 1), 2.0)
    assert z_x.serial is None and z_y.serial is None and trace.override_expired == ""

    again, shown = ask(monkeypatch, tmp_path, ["", "", "", "SN9"], indicators[::-1])
    assert "Gauges met before: SN9 (Sylvac S_Dial Work, certificate C-2025-118" in shown
    assert again.operator == "A. Technician"  # remembered, offered, accepted
    assert again.ambient_start_c is None
    assert again.identities["y_x"] == trace.identities["y_x"]  # nothing typed twice
    assert load_inventory(tmp_path / "instruments.toml").find("SN9") == KnownGauge(
        "SN9", make="Sylvac", model="S_Dial Work", certificate="C-2025-118",
        calibrated=datetime.date(2025, 6, 1), due=datetime.date(2026, 6, 1),
        uncertainty_mm=0.002, uncertainty_k=2.0)


def test_an_expired_gauge_is_changed_for_a_valid_one(tmp_path, monkeypatch):
    indicators = [Indicator("gauge y_x (/dev/ttyUSB0)", ("y_x",))]
    trace, shown = ask(monkeypatch, tmp_path, [
        "", "", "OLD1", "", "", "", "2024-01-01", "2025-01-01", "", "", "c",
        "NEW2", "", "", "", "2025-09-01", "2026-09-01", "", ""], indicators)
    assert "y_x (serial OLD1, due 2025-01-01) is past the due date" in shown
    assert trace.identities["y_x"]["serial"] == "NEW2" and trace.override_expired == ""


def test_a_typo_is_typed_again_before_it_is_remembered_and_no_u_is_said(tmp_path,
                                                                         monkeypatch):
    """A new gauge is shown whole and confirmed before instruments.toml keeps it; a
    certificate without its U is said to leave the budget incomplete, and asked again
    unless the technician means it."""
    indicators = [Indicator("gauge y_x (/dev/ttyUSB0)", ("y_x",))]
    trace, shown = ask(monkeypatch, tmp_path, [
        "", "",
        "SN99", "Sylvac", "S_Dial Work", "C-1", "2025-06-01", "2026-06-01",
        "",  # no U: said, and asked whether to leave it so
        "n", "0.002", "",
        "n",  # not right: the serial was mistyped
        "SN9", "", "", "", "", "", "", "",  # the serial again, the rest as offered
        ""], indicators)
    assert "no U: without the certificate's expanded uncertainty this gauge's calibration " \
           "is left out of the uncertainty budget" in " ".join(shown.split())
    assert "SN99: Sylvac S_Dial Work, certificate C-1, calibrated 2025-06-01, due " \
           "2026-06-01, U = 0.002 mm (k = 2)" in shown
    inventory = load_inventory(tmp_path / "instruments.toml")
    assert inventory.find("SN99") is None  # the typo never stored
    assert inventory.find("SN9") == KnownGauge(
        "SN9", make="Sylvac", model="S_Dial Work", certificate="C-1",
        calibrated=datetime.date(2025, 6, 1), due=datetime.date(2026, 6, 1),
        uncertainty_mm=0.002, uncertainty_k=2.0)
    assert trace.identities["y_x"]["serial"] == "SN9"

    # a certificate left without U on purpose: kept so, the record will say why
    trace, _ = ask(monkeypatch, tmp_path / "other", [
        "", "", "SN5", "", "", "C-5", "", "", "", "y", ""], indicators)
    assert trace.identities["y_x"]["certificate"] == "C-5"
    assert "uncertainty_mm" not in trace.identities["y_x"]


def test_temperatures_typed_and_refused():
    assert temperature("21,5") == 21.5 and temperature("19.0 °C") == 19.0
    assert temperature("") is None
    with pytest.raises(ValueError, match="between -40 and 80"):
        temperature("98.6")  # a Fahrenheit value


def test_a_broken_inventory_is_named_with_its_line(tmp_path):
    (tmp_path / "instruments.toml").write_text('[[gauges]]\nserial = "A"\ndue = "soon"\n')
    with pytest.raises(InputError, match=r"instruments\.toml:3: gauges\[0\]\.due must be a "
                                         r"date"):
        load_inventory(tmp_path / "instruments.toml")


def test_a_serial_twice_in_the_inventory_is_refused(tmp_path):
    """A hand-edited inventory with two entries for one gauge: the later one silently won."""
    (tmp_path / "instruments.toml").write_text('[[gauges]]\nserial = "A"\ndue = 2027-01-01\n'
                                               '[[gauges]]\nserial = "A"\ndue = 2026-01-01\n')
    with pytest.raises(InputError) as caught:
        load_inventory(tmp_path / "instruments.toml")
    assert str(caught.value) == (f"{tmp_path / 'instruments.toml'}:5: serial 'A' twice "
                                 "(gauges[0] at line 2): one entry a gauge; delete the one "
                                 "that is out of date")


def test_a_serial_typed_again_that_is_known_takes_the_known_gauge(tmp_path, monkeypatch):
    """The typo was in the serial: typed again, it names a gauge met before, which is
    taken as known; the answers given for the typo never overwrite its certificate."""
    indicators = [Indicator("gauge y_x (/dev/ttyUSB0)", ("y_x",))]
    ask(monkeypatch, tmp_path, ["", "", "SN9", "Sylvac", "", "C-1", "2025-06-01",
                                "2026-06-01", "0.002", "", ""], indicators)
    known = load_inventory(tmp_path / "instruments.toml").find("SN9")
    trace, shown = ask(monkeypatch, tmp_path, [
        "", "",
        "SN6", "Mitutoyo", "", "C-9", "", "", "0,004", "",  # a serial mistyped
        "n", "SN9"], indicators)  # not right: SN9, the gauge met before
    assert "OK  SN9: Sylvac, certificate C-1" in shown
    assert trace.identities["y_x"] == known.identity()
    inventory = load_inventory(tmp_path / "instruments.toml")
    assert inventory.find("SN9") == known and inventory.find("SN6") is None


def test_numbers_refused_in_words():
    for typed in ("twenty", "2O", "nan", "inf"):
        with pytest.raises(ValueError, match=rf"'{typed}' is not a number: type a "
                                             r"temperature in °C \(for example 20\.5\)"):
            temperature(typed)
    assert _positive("0,0015 mm") == 0.0015
    with pytest.raises(ValueError, match=r"'1\.5 µm' is not a number: type the "
                                         r"certificate's U in mm \(for example 0\.0015"):
        _positive("1.5 µm")
    with pytest.raises(ValueError, match=r"1\.5 mm is more than an indicator's certificate "
                                         r"states \(at most 0\.1 mm\): micrometres written"):
        _positive("1.5")
