"""One quantity, one face (issue 38.8): a value and its std written at one rounding on
every line that states them, a p-value written one way on the terminal and the page."""

from __future__ import annotations

import re

import pytest

from ogacq.cli.render import print_demo_diagnosis
from ogacq.cli.report_cmd import report_diagnosis
from ogacq.diagnose.diagnosis import Diagnosis, diagnose
from ogacq.identify.consistency import format_p
from ogacq.io.tables import write_readings
from ogacq.record.document import build_record
from ogacq.report import build_report, collect, parse_diagnosis
from ogacq.session.convert import import_readings
from ogacq.session.store import load_session
from ogacq.uncertainty.reporting import measure
from tests.diagnose.campaigns import MACHINE, simulate

HIDDEN = {"encoder_scale.x": 3000.0}


@pytest.fixture(scope="module")
def scaled(tmp_path_factory) -> tuple[Diagnosis, object]:
    """The papers' campaign on a machine whose x encoder reads 3000 ppm long, as a
    session (the report reads sessions) and its diagnosis."""
    folder = tmp_path_factory.mktemp("face")
    obs = simulate(HIDDEN, 1)
    write_readings(folder / "readings.csv", obs.layout, obs.values)
    session = load_session(import_readings(folder / "readings.csv", MACHINE,
                                           folder / "session.jsonl"))
    from ogacq.session.convert import session_observations

    return diagnose(session_observations(session)), session


def test_the_demos_effects_table_rounds_as_the_effects_line_does(scaled, capsys,
                                                                 monkeypatch):
    """The demo's table said "+382.6237 | 23.8388 ppm", its effects line "+383 ± 24 ppm":
    the table now writes the value (and the truth) at the std's decimal place, the std to
    two significant digits, the face of every other line (JCGM 100:2008 7.2.6)."""
    monkeypatch.setenv("COLUMNS", "200")
    diagnosis, _ = scaled
    (effect,) = [e for e in diagnosis.effects if e.name == "encoder_scale.x"]
    print_demo_diagnosis(diagnosis, HIDDEN)
    row = next(line for line in capsys.readouterr().out.splitlines()
               if line.strip().startswith("encoder_scale.x"))
    cells = [c.strip() for c in re.split(r"[│┃]", row)]
    value, std, truth, unit = cells[1:5]
    assert f"{value} ± {std} {unit}" == measure(effect.value, effect.std, effect.unit)
    assert truth == "+3000" if std == "100" else truth.startswith("+3000")
    assert len(std.replace(".", "").lstrip("0")) <= 3, std  # two digits (100: tens)


def test_the_pages_chi_square_table_writes_p_as_the_verdict_does(scaled):
    """The page's "along each axis" table said p 4.58e-13 beside the verdict's
    4.6e-13: both through format_p now."""
    diagnosis, session = scaled
    view = parse_diagnosis(report_diagnosis(diagnosis, session))
    html = build_report(collect(session, diagnosis=view), build_record(session)).html
    text = re.sub(r"\s+", " ", re.sub(r"<[^>]+>", " ", html))
    base = view.chi2["base"]
    assert base.p < 1e-4  # the case where the two faces differed
    assert re.search(rf"joint offsets only [\d.]+ {base.dof} {re.escape(format_p(base.p))} ",
                     text), text[text.find("joint offsets only"):][:200]


def test_the_pages_verdict_writes_the_misfit_per_dof_as_its_text_does(scaled):
    """The record's verdict table said "χ² per dof 532.2801" beside its text's "per dof
    532": both to three significant digits now (record.json keeps its four decimals)."""
    _, session = scaled
    record = build_record(session)
    per_dof = record["verdict"]["chi2_dof"]
    assert per_dof != float(f"{per_dof:.3g}")  # the case where the two faces differed
    html = build_report(collect(session), record).html
    text = re.sub(r"\s+", " ", re.sub(r"<[^>]+>", " ", html))
    assert f"χ² per dof {per_dof:.3g} " in text and f"per dof {per_dof:.3g}," in text


def test_the_pages_budget_and_monte_carlo_check_are_rounded_as_u_is(scaled):
    """The budget printed each input as recorded ("0.000288675 mm", a sensitivity
    "1.110040519") and the Monte-Carlo check nine digits of every figure: a u now to two
    significant digits, the sensitivity to three, the check's mean and interval at the
    budget's u_c's decimal place. record.json keeps every digit."""
    _, session = scaled
    record = build_record(session)
    rows = [r for rows in record["budget"].values() for r in rows]
    resolution = next(r for r in rows if r["source"] == "display resolution")
    assert resolution["u_input"] == pytest.approx(0.001 / 12 ** 0.5, abs=1e-9)
    html = build_report(collect(session), record).html
    text = re.sub(r"\s+", " ", re.sub(r"<[^>]+>", " ", html))
    budget = text[text.index("Uncertainty budget"):text.index("History")]
    assert "Monte-Carlo check" in budget and "rectangular 0.00029 mm" in budget, budget
    assert re.findall(r"\d\.\d{6,}", budget) == [], budget
