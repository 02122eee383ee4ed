"""A newcomer's path through ``ogacq run``: a campaign run again records into the next
session of its series (or the one ``--session`` names), what the record will lack is
said before anything moves, and the end says the verdict, the record id and the next
command, the offsets with their U (k = 2) as the record states them."""

from __future__ import annotations

import json
import re

import pytest

from ogacq.campaign.campaign_file import read_campaign
from ogacq.campaign.traceability import traceability_gaps
from ogacq.errors import InputError
from ogacq.session.records import EndRecord
from ogacq.session.series import earlier_in_series, next_session
from ogacq.session.store import SessionWriter, load_session
from tests.campaign.conftest import CONTROLLER, HEAD, MACHINE, gauge, write_campaign
from tests.writeback.conftest import FAST_STABILITY, ogacq_here, synthetic_session


def test_the_series_of_a_campaigns_sessions(tmp_path):
    base = tmp_path / "session.jsonl"
    campaign = tmp_path / "campaign.toml"
    assert next_session(base).path == base and next_session(base).previous is None
    synthetic_session(base, campaign, offsets_mm={"x": 0.1, "y": 0.0, "z": 0.0})
    assert next_session(base).path == tmp_path / "session-2.jsonl"
    assert next_session(base).previous == base
    # a second session not finished (killed): resumed, never passed over
    with SessionWriter.create(tmp_path / "session-2.jsonl", {"plan": None}) as writer:
        writer.write(EndRecord(status="stopped", reason="the operator stopped it"))
    with pytest.raises(InputError, match=r"session-2.jsonl: a session already exists here and "
                                         r"its campaign has not finished: resume it"):
        next_session(base)
    assert earlier_in_series(tmp_path / "session-2.jsonl") == [base]
    assert earlier_in_series(base) == [] and earlier_in_series(tmp_path / "x-2.jsonl") == []


def test_run_again_with_session_warns_first_and_ends_with_what_to_do(
        tmp_path, capsys, monkeypatch, caplog, ogacq_home):
    campaign_dir = tmp_path / "campaign"
    monkeypatch.setenv("COLUMNS", "250")  # rich would wrap the long lines
    # a first use: ogacq's data folder does not exist yet (made, for its owner only)
    ogacq_home = ogacq_home / "first use"
    monkeypatch.setenv("OGACQ_HOME", str(ogacq_home))
    path = write_campaign(campaign_dir, seed=3, extra="cycles = 1\n" + FAST_STABILITY,
                          line_at_speed=True)
    first = ogacq_here(capsys, monkeypatch, "run", path)
    assert first.returncode == 0, first.stderr
    # missing traceability said when the run starts, not first found in record.json
    warned = [r.getMessage() for r in caplog.records if r.levelname == "WARNING"]
    assert any("no operator is named" in w for w in warned), warned
    assert any("gauges y_x, z_x, x_y, z_y, x_z, y_z have no calibration certificate" in w
               for w in warned), warned

    # the headline: each offset with U (k = 2) to two significant digits, the value at
    # the same decimal place, as in the record; no std
    record = load_session(campaign_dir / "session.jsonl")
    assert record.finished
    table = [line for line in first.stdout.splitlines() if "joint_offset." in line]
    assert len(table) == 3
    for line in table:
        value, u, k = re.search(r"joint_offset\.\w\s*│\s*([+-]\d+\.(\d+))\s*│\s*(\d\.(\d+))"
                                r"\s*│\s*(\S+)", line).group(1, 3, 5)
        assert len(value.split(".")[1]) == len(u.split(".")[1]), line
        assert len(u.lstrip("0.")) == 2 and k == "2", line
    assert "std" not in first.stdout

    # the end: the verdict, the record's id, the next command
    # (a real-time rehearsal of one cycle on a loaded machine may read a posture before
    # it is still: the verdict is then "NOT within", and the next step a diagnosis)
    end = first.stdout[first.stdout.index("verdict:"):]
    said = re.search(r"verdict: (within|NOT within) the gauge noise \(.* test, combined p = "
                     r"[0-9.e+-]+, judged at the 0.01 level\)", end)
    assert said, end
    record_id = re.search(r"record: (OGQ-\d{8}-[0-9a-f]{8})", end).group(1)
    session = campaign_dir / "session.jsonl"
    if said.group(1) == "within":
        assert f"next: ogacq report {session}" in end
        assert "a rehearsal: the simulated controller stopped with the command" in end
    else:
        assert f"next: ogacq diagnose {session}" in end and f"ogacq report {session}" in end
    # ... the id the history recorded it under
    listed = ogacq_here(capsys, monkeypatch, "history", "--json", "machine")
    assert [c["record"] for c in json.loads(listed.stdout)["calibrations"]] == [record_id]

    # again, into the file --session names (and so refused once it exists)
    other = campaign_dir / "check.jsonl"
    again = ogacq_here(capsys, monkeypatch, "run", path, "--session", other)
    assert again.returncode == 0, again.stderr
    assert load_session(other).finished
    assert not (campaign_dir / "session-2.jsonl").exists()
    # both in the one history of ogacq's data folder, found from any folder
    assert f"1 calibration recorded in {ogacq_home / 'history.sqlite'}" in again.stderr
    assert ogacq_home.stat().st_mode & 0o777 == 0o700
    monkeypatch.chdir(tmp_path)
    listed = ogacq_here(capsys, monkeypatch, "history", "--json", "machine")
    assert len(json.loads(listed.stdout)["calibrations"]) == 2
    refused = ogacq_here(capsys, monkeypatch, "run", path, "--session", other)
    assert refused.returncode == 2 and "a session already exists here" in refused.stderr


def test_what_the_record_will_lack_is_named_gauge_by_gauge(tmp_path):
    (tmp_path / "machine.toml").write_text(MACHINE)
    certified = 'certificate = "C-1"\nuncertainty_mm = 0.002\nuncertainty_k = 2.0\n'
    gauges = [gauge("y_x", "/dev/ttyUSB0") + certified, gauge("z_x", "/dev/ttyUSB1")
              + 'certificate = "C-2"\n'] + [
        gauge(k, f"/dev/ttyUSB{n}") for n, k in enumerate(("x_y", "z_y", "x_z", "y_z"), 2)]
    path = tmp_path / "campaign.toml"
    path.write_text('operator = "J. Martin"\n' + HEAD + CONTROLLER + "".join(gauges))
    assert traceability_gaps(read_campaign(path)) == [
        "gauges x_y, z_y, x_z, y_z have no calibration certificate ([[gauges]] certificate, "
        "uncertainty_mm, uncertainty_k): their calibration is left out of the uncertainty "
        "budget, which the record will mark incomplete",
        "gauge z_x has a certificate without its expanded uncertainty ([[gauges]] "
        "uncertainty_mm and uncertainty_k): its calibration is left out of the uncertainty "
        "budget, which the record will mark incomplete"]


def test_a_reading_far_from_its_repeats_sends_the_end_to_diagnose_not_to_a_write(tmp_path):
    """A slip of 2 mm swells the noise measured from the repeats until the offsets alone
    pass: the campaign's end names the reading and points at diagnose, never at
    `offsets write`."""
    from ogacq.cli.campaign_end import next_steps
    from ogacq.diagnose.outliers import described_outliers
    from ogacq.identify.consistency import fit_verdict
    from ogacq.session.identification import identify_session

    (tmp_path / "campaign.toml").write_text("")
    steps_of = {}
    for name, slip in (("clean", None), ("slipped", (33, 2.0))):
        path = synthetic_session(tmp_path / f"{name}.jsonl", tmp_path / "campaign.toml",
                                 offsets_mm={"x": 0.3, "y": -0.2, "z": 0.1}, slip=slip)
        session = load_session(path)
        fit = identify_session(session)
        assert fit_verdict(fit).consistent
        steps_of[name] = next_steps(session, fit_verdict(fit), True, simulated=False,
                                    outliers=described_outliers(fit))
    assert steps_of["clean"][0].command.startswith("ogacq offsets write")
    first = steps_of["slipped"][0]
    assert first.command.startswith("ogacq diagnose") and "1 reading lies far" in first.why
    assert not any("offsets write" in s.command for s in steps_of["slipped"])


def test_a_campaign_against_ogacq_sim_names_its_validation_run(tmp_path):
    """`ogacq sim`'s drives say "ogacq simulator", so its campaign is a rehearsal; but
    they still serve once the run ends: the end names the write-back and the validation
    run, as on a machine (it said only the write, its validation left unsaid). The
    built-in simulator stops with its command: nothing to write to."""
    from ogacq.cli.campaign_end import next_steps
    from ogacq.identify.consistency import fit_verdict
    from ogacq.session.identification import identify_session

    campaign = tmp_path / "campaign.toml"
    campaign.write_text("")
    session = load_session(synthetic_session(tmp_path / "session.jsonl", campaign,
                                             offsets_mm={"x": 0.3, "y": -0.2, "z": 0.1}))
    verdict = fit_verdict(identify_session(session))
    assert verdict.consistent
    served = next_steps(session, verdict, True, simulated=True, rehearsal_writeback=True)
    assert [s.command for s in served[:2]] == [
        f"ogacq offsets write {session.path}", f"ogacq run {campaign.resolve()}"]
    gone = next_steps(session, verdict, True, simulated=True)
    assert not any(s.command.startswith(("ogacq offsets", "ogacq run")) for s in gone)
    assert "stopped with the command" in gone[-1].why
