"""The end of `ogacq calibrate`, as of every campaign: the outcome, the record's id and
page, and the next command, which depends on how the procedure ended."""

from __future__ import annotations

from pathlib import Path

import pytest

from ogacq.calibration.procedure import Outcome
from ogacq.cli.render_calibrate import next_steps, print_outcome

FOLDER = Path("/runs/cal")
REPORT = FOLDER / "report" / "report.html"
RECORD = {"format": "ogacq-record/1", "id": "OGQ-20261128-0b1d2078"}


def outcome(kind: str, **kwargs) -> Outcome:
    return Outcome(FOLDER, "C-20261128-bd947c", kind, "the reason",
                   evidence=FOLDER / "calibration.jsonl",
                   validation=FOLDER / "validation.jsonl", record=RECORD, **kwargs)


def commands(kind: str) -> list[str]:
    return [s.command for s in next_steps(outcome(kind), REPORT)]


def test_validated_points_to_the_record():
    assert commands("validated") == [f"open {REPORT}"]
    assert commands("nothing to correct") == [f"open {REPORT}"]


def test_improved_points_to_what_is_left_and_a_second_pass():
    steps = next_steps(outcome("improved"), REPORT)
    assert steps[0].command == f"ogacq diagnose {FOLDER / 'validation.jsonl'}"
    assert "second `ogacq calibrate`" in steps[1].why and steps[1].command == ""
    assert steps[2].command == f"open {REPORT}"


@pytest.mark.parametrize("kind", ["restored", "refused"])
def test_a_correction_not_kept_points_to_the_diagnosis(kind):
    assert commands(kind)[0] == f"ogacq diagnose {FOLDER / 'calibration.jsonl'}"


def test_without_a_page_the_report_command_issues_it():
    steps = next_steps(outcome("validated"), None)
    assert [s.command for s in steps] == [f"ogacq report {FOLDER / 'calibration.jsonl'}"]


def test_the_end_names_the_record_and_the_next_command(capsys, monkeypatch):
    monkeypatch.setenv("COLUMNS", "200")  # at 80 columns the last line wraps between words
    print_outcome(outcome("validated"), REPORT)
    out = capsys.readouterr().out.splitlines()
    assert out == ["calibration C-20261128-bd947c: validated: the reason",
                   f"record: {RECORD['id']} ({REPORT})",
                   f"next: open {REPORT}   (the calibration record: as found and as left)"]


def test_a_restore_ends_on_stderr(capsys):
    print_outcome(outcome("restored"), REPORT)
    captured = capsys.readouterr()
    assert captured.out == ""
    assert "next: ogacq diagnose" in captured.err and RECORD["id"] in captured.err


def test_a_long_refusal_fits_80_columns_between_words(capsys, monkeypatch):
    """The refusal was one line of some 600 characters, cut mid-word by the terminal."""
    monkeypatch.setenv("COLUMNS", "80")
    reason = " ".join(["the validation fit is not within the noise and its misfit grew"] * 8)
    done = Outcome(FOLDER, "C-20261128-bd947c", "refused", reason,
                   evidence=FOLDER / "calibration.jsonl", record=RECORD)
    print_outcome(done, REPORT)
    err = capsys.readouterr().err
    assert err.splitlines() and all(len(line) <= 80 for line in err.splitlines()), err
    assert " ".join(err.split()).startswith(f"calibration C-20261128-bd947c: refused, "
                                            f"nothing written: {reason}")
