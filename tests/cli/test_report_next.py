"""``ogacq report`` ends with the next command (issue 38.5): it ended with the page's
path. What a technician does once the record is read, naming the file, or why there is
nothing more; and it says on stderr what its seconds of work are, once its inputs are
found good (it was silent for 15-18 s)."""

from __future__ import annotations

from pathlib import Path

import pytest

from ogacq.cli.app import main
from ogacq.cli.report_next import after_report
from ogacq.io.tables import write_readings
from ogacq.record.calibration_record import CalibrationRecord
from ogacq.record.document import build_record
from ogacq.session.convert import import_readings
from ogacq.session.identification import recorded_identification
from ogacq.session.store import load_session
from ogacq.writeback.audit import AuditLog
from tests.diagnose.campaigns import MACHINE, simulate

OLD = {"x": 0.0, "y": 0.0, "z": 0.0}
NEW = {"x": -2.0, "y": -2.0, "z": 2.0}


def _session(folder: Path, name: str, effects: dict[str, float]) -> Path:
    """The papers' campaign (a readings table imported as a session: no campaign file,
    no simulator), on a machine with ``effects`` beside the joint offsets."""
    obs = simulate(effects, 3)
    write_readings(folder / f"{name}.csv", obs.layout, obs.values)
    return import_readings(folder / f"{name}.csv", MACHINE, folder / f"{name}.jsonl")


@pytest.fixture(scope="module")
def sessions(tmp_path_factory) -> dict[str, Path]:
    folder = tmp_path_factory.mktemp("next")
    return {"clean": _session(folder, "clean", {}),
            "square": _session(folder, "square", {"squareness.xy": 1.0})}


def _write_offsets(session: Path) -> None:
    """An `offsets write` recorded done in ``session``, as its audit records it."""
    with AuditLog(load_session(session)) as log:
        log.record("intent", operation="write-1", action="write", profile="cia402",
                   old_mm=OLD, new_mm=NEW)
        log.record("done", operation="write-1", action="write", old_mm=OLD, new_mm=NEW)


def _steps(session: Path, validation: Path | None = None) -> list[tuple[str, str]]:
    loaded = load_session(session)
    after = load_session(validation) if validation is not None else None
    record = CalibrationRecord.from_json(build_record(loaded, validation=after))
    fit = recorded_identification(loaded)
    after_fit = recorded_identification(after) if after is not None else None
    return [(s.command, s.why) for s in after_report(loaded, after, record, fit, after_fit)]


def test_a_campaign_within_the_noise_is_written_next(sessions):
    session = sessions["clean"]
    (command, why), *_ = _steps(session)
    assert command == f"ogacq offsets write {session}"


def test_a_campaign_the_offsets_do_not_explain_is_diagnosed_next(sessions):
    session = sessions["square"]
    assert _steps(session)[0][0] == f"ogacq diagnose {session}"


def test_offsets_written_wait_for_their_validation_then_its_record(sessions, tmp_path):
    """Once `offsets write` recorded its write in the session, the validation is next;
    once the validation ran (the next session of its series), the record with it."""
    session = tmp_path / "session.jsonl"
    session.write_bytes(sessions["clean"].read_bytes())
    _write_offsets(session)
    ((command, why),) = _steps(session)
    assert command == ""  # no campaign file to run it from: said in words
    assert f"a validation campaign, then `ogacq report {session} --after" in why
    validation = tmp_path / "session-2.jsonl"
    validation.write_bytes(sessions["clean"].read_bytes())
    assert _steps(session)[0][0] == f"ogacq report {session} --after {validation}"


def test_the_record_as_found_and_as_left_is_the_end(sessions):
    ((command, why),) = _steps(sessions["square"], sessions["clean"])
    assert command == "" and why.startswith("nothing more: the record states the machine "
                                            "as found and as left")
    # a validation not within the noise is what to look at next
    assert _steps(sessions["clean"], sessions["square"])[0][0] == \
        f"ogacq diagnose {sessions['square']}"


def test_the_command_says_its_work_then_ends_with_the_next_command(sessions, tmp_path,
                                                                   capsys, monkeypatch):
    monkeypatch.setenv("COLUMNS", "300")
    session = sessions["clean"]
    page = tmp_path / "out" / "report.html"
    assert main(["report", str(session), "--out", str(page.parent), "--history",
                 "none"]) == 0
    out, err = capsys.readouterr()
    assert out.splitlines()[0] == str(page)  # first, as a script reads it
    assert out.splitlines()[-1] == (f"next: ogacq offsets write {session}   (write the "
                                    "offsets to the controller (shown and confirmed first))")
    assert err.startswith(f"ogacq report: issuing the record of {session}: its diagnosis, "
                          "uncertainty budget, Monte-Carlo check and figures")


def test_the_command_loads_the_figures_libraries_only_after_saying_so():
    """The page's libraries (matplotlib, the report package) load once the command has
    said what it does, not when typer imports the command (seconds of silence)."""
    import subprocess
    import sys

    probe = ("import sys, ogacq.cli.report_cmd; "
             "print(sorted(m for m in ('matplotlib', 'ogacq.report') if m in sys.modules))")
    ran = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True,
                         timeout=60, check=True)
    assert ran.stdout.strip() == "[]"


def test_a_validation_after_a_write_from_the_diagnosis_is_judged_with_its_effects(
        sessions, tmp_path):
    """After `offsets write --from-diagnosis` the squareness stays: the validation's
    joint offsets alone are NOT within the noise, with the squareness carried over they
    are (issue 38.4): the record as found and as left is the end, not a diagnosis."""
    session = tmp_path / "session.jsonl"
    session.write_bytes(sessions["square"].read_bytes())
    _write_offsets(session)
    obs = simulate({"squareness.xy": 1.0}, 4, offsets={f"joint_offset.{a}": 0.002
                                                       for a in "xyz"})
    write_readings(tmp_path / "after.csv", obs.layout, obs.values)
    validation = import_readings(tmp_path / "after.csv", MACHINE, tmp_path / "session-2.jsonl")
    from ogacq.identify.consistency import fit_verdict

    assert not fit_verdict(recorded_identification(load_session(validation))).consistent
    ((command, why),) = _steps(session, validation)
    assert command == "" and why.startswith("nothing more: the record states the machine")


def test_a_campaign_of_calibrates_procedure_reported_alone_points_to_its_record(
        sessions, tmp_path):
    """calibrate's validation.jsonl reported alone sent the technician to diagnose it
    (or to write its offsets): the procedure logged beside it wrote and judged what it
    found, and its record as found and as left is the procedure's own page."""
    import shutil

    from ogacq.calibration.log import ProcedureLog

    validation = tmp_path / "validation.jsonl"
    shutil.copyfile(sessions["square"], validation)
    assert _steps(validation)[0][0] == f"ogacq diagnose {validation}"  # alone, unknown
    log = ProcedureLog.create(tmp_path, {"mode": "simulator"})
    log.add("campaign", session=str(validation))
    log.close()
    (command, why), = _steps(validation)
    assert command == "" and "nothing more here: validation.jsonl is a campaign of the " \
        "`ogacq calibrate` procedure" in why and str(tmp_path / "procedure.jsonl") in why
    page = tmp_path / "report" / "report.html"
    page.parent.mkdir()
    page.write_text("<html></html>")
    assert _steps(validation)[0][0] == f"open {page}"
