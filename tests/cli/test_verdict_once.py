"""The verdict's paragraph once a command (issue 38.6): "lack-of-fit F test ... combined
p ... judged at the 0.01 level" was printed four or five times a demo. The first
verdict a command states is said in full; each later one is one line, its words and
its p against the level, referring to it."""

from __future__ import annotations

import re

from ogacq.cli.render import print_demo_diagnosis
from ogacq.cli.verdict_text import new_command, one_line, paragraph, recorded_paragraph
from ogacq.diagnose.diagnosis import diagnose
from ogacq.identify.consistency import format_p
from tests.diagnose.campaigns import simulate

HIDDEN = {"squareness.xy": 0.5}


def _flat(text: str) -> str:
    return " ".join(text.split())


def test_the_demos_verdicts_are_explained_once_then_said_in_a_line(capsys, monkeypatch):
    """The demo's diagnosis (the offsets alone, then with the squareness), its end, and a
    validation recorded by the procedure: one paragraph, then one line each."""
    monkeypatch.setenv("COLUMNS", "120")
    d = diagnose(simulate(HIDDEN, 1))
    print_demo_diagnosis(d, HIDDEN)
    end = one_line(d.base)
    validation = recorded_paragraph({**d.final.to_json(), "text": d.final.describe(),
                                     "state": d.final.state, "p_value": d.final.p_value})
    said = _flat(capsys.readouterr().out + "\n" + end + "\n" + validation)
    assert said.count("judged at the 0.01 level") == 1, said
    assert said.count(" test: ") == 1  # the test named and its statistic shown once
    assert _flat(d.base.describe()) in said  # the first in full
    # each later one: its words and its p against the level, nothing lost of the verdict
    final = (f"within the gauge noise (combined p = {format_p(d.final.p_value)} ≥ 0.01, "
             "the test as above)")
    assert f"with these effects the fit is {final}" in said
    assert end == (f"NOT within the gauge noise (combined p = {format_p(d.base.p_value)} "
                   "< 0.01, the test as above)")
    assert validation == final


def test_a_command_that_said_no_paragraph_ends_with_the_test_and_its_level():
    """`ogacq run` states no paragraph before its end: the end's one line names the test
    and the level, as before."""
    d = diagnose(simulate(HIDDEN, 1))
    assert one_line(d.base) == d.base.summary()
    assert re.search(r"\(chi-square test, combined p = \S+, judged at the 0.01 level\)",
                     one_line(d.base))


def test_each_command_explains_its_first_verdict_again():
    d = diagnose(simulate(HIDDEN, 1))
    assert paragraph(d.base) == d.base.describe()
    assert paragraph(d.base) != d.base.describe()
    new_command()  # what run_app does as a command starts
    assert paragraph(d.final) == d.final.describe()
