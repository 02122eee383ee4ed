"""A drive profile is one identity wherever it is named (issue 38.7): a campaign whose
[controller] names its profile by file records the profile's own name and the file's
checksum, and writes back through the same file (it was refused as another
profile: the path was compared with the name). And a campaign against `ogacq sim`,
whose drives say "ogacq simulator" (Modbus Read Device Identification), is a
rehearsal end to end (issue 38.2): the session, record.json and the history."""

from __future__ import annotations

import hashlib
import json
import shutil

from ogacq_drivers.axes.profile import profiles_folder
from ogacq.cli.report_cmd import issue_report
from ogacq.session.records import OffsetsRecord
from ogacq.session.store import load_session
from tests.writeback.conftest import controller_offsets, ogacq_here, sim_campaign, simulator


def test_a_profile_file_campaign_is_simulated_and_writes_back_through_it(
        tmp_path, capsys, monkeypatch):
    monkeypatch.setenv("COLUMNS", "200")
    own = tmp_path / "my-drive.toml"  # a user's profile file: the built-in one, copied
    shutil.copyfile(profiles_folder() / "cia402.toml", own)
    history = tmp_path / "history.sqlite"
    with simulator(tmp_path, "cia402", seed=6) as info:
        campaign = sim_campaign(tmp_path, info, name="mine",
                                extra="cycles = 1\n" + "\n[stability]\nreadings = 2\n"
                                      "tolerance_mm = 0.003\ntimeout_s = 1.0\n")
        campaign.write_text(campaign.read_text().replace('profile = "cia402"',
                                                         f'profile = "{own}"'))
        ran = ogacq_here(capsys, monkeypatch, "run", campaign, "--history", history)
        assert ran.returncode == 0, ran.stderr
        session = load_session(tmp_path / "mine.jsonl")
        controller = session.header.station["controller"]
        assert controller["profile"] == str(own)
        assert controller["profile_name"] == "cia402"
        assert controller["profile_sha256"] == hashlib.sha256(own.read_bytes()).hexdigest()
        assert controller["identification"]["x"]["vendor"] == "ogacq simulator"

        written = ogacq_here(capsys, monkeypatch, "offsets", "write", session.path, "--yes",
                             "--force", "--history", history)
        assert written.returncode == 0, written.stdout + written.stderr
        # --force: one cycle's fit may be judged unreliable; the profile must not be
        intent = load_session(session.path).of_type(OffsetsRecord)[0]
        assert "other_profile" not in intent.details["forced"], intent.details["refusals"]
        assert intent.details["profile"] == "cia402"
        assert any(abs(v) > 0 for v in controller_offsets(campaign).values())

    assert "SIMULATED" in ran.stdout  # the run's end
    assert session.header.simulated is True
    page, _ = issue_report(load_session(session.path), tmp_path / "report")
    record = json.loads((tmp_path / "report" / "record.json").read_text())
    assert record["simulated"] is True
    assert record["method"]["controller"]["identification"]["y"]["vendor"] == \
        "ogacq simulator"
    assert "SIMULATED" in page.read_text(encoding="utf-8")
    listed = ogacq_here(capsys, monkeypatch, "history", "--history", history, "--json")
    machine = json.loads(listed.stdout)["machines"][0]
    shown = ogacq_here(capsys, monkeypatch, "history", machine["name"], "--history", history,
                       "--json")
    assert [c["simulated"] for c in json.loads(shown.stdout)["calibrations"]] == [True]
