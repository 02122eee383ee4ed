"""Issue 15, end to end on the simulator: three calibrations of one machine on
different dates and at different temperatures, with a drift of its x joint offset
injected before the third (the simulator's hidden truth, an effects file), land in
SQLite through ``ogacq run``; ``ogacq history`` shows the three and flags that
drift, and the same sessions in a real PostgreSQL server give the same history."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from tests.campaign.conftest import MACHINE
from tests.writeback.conftest import ogacq_here

NAME = "OG-e2e cell 1"
# (date, simulated ambient, hidden x offset): the third calibration finds x 80 um
# further, far beyond the few um of its U. The shop's temperature differs a few
# tenths of a degree: the simulated legs expand with it (about 3.6 um of apparent
# offset per degC on this machine), which a change of 1.5 degC would show as a
# change beyond U of y and z too, rightly: the budget's temperature rows hold the
# uncertainty of each campaign's temperature, not a correction between campaigns.
CALIBRATIONS = [("2026-01-10T09:00:00", 20.2, 0.400),
                ("2026-02-14T10:30:00", 20.5, 0.400),
                ("2026-03-20T08:15:00", 20.3, 0.480)]


def campaign(folder: Path, index: int) -> Path:
    date, ambient, x = CALIBRATIONS[index]
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "machine.toml").write_text(f'name = "{NAME}"\nserial = "SIM-0001"\n{MACHINE}')
    (folder / "effects.toml").write_text(f"[joint_offset]\nx = {x}\ny = -0.25\nz = 0.15\n")
    path = folder / "campaign.toml"
    # One cycle, fast simulated time: 24 readings in about a second, after a settle the
    # simulated ringing (time constant 0.15 s) has died down in. The gauges' certificates
    # and the simulator's thermometer (start and end) make the budget complete, so U
    # holds the systematic sources a repeat does not vary and a drift is judged against
    # what a real history would judge it against, not the 4-dof scatter alone.
    gauges = "".join(
        f'[[gauges]]\ngauge = "{key}"\nmake = "Mitutoyo"\nmodel = "543-790B"\n'
        f'serial = "G-{key}"\ncertificate = "CAL-2025-{key}"\ncalibrated = 2025-12-01\n'
        f"due = 2026-12-01\nuncertainty_mm = 0.002\nuncertainty_k = 2.0\n\n"
        for key in ("y_x", "z_x", "x_y", "z_y", "x_z", "y_z"))
    path.write_text(f'machine = "machine.toml"\nsession = "session.jsonl"\n'
                    f'operator = "A. Technician"\n\n{gauges}'
                    f"[protocol]\ncycles = 1\nsettle_s = 1.0\n\n"
                    f"[stability]\nreadings = 2\ntolerance_mm = 0.003\ntimeout_s = 2.0\n\n"
                    f'[simulator]\nseed = 3\nspeed = 100\neffects = "effects.toml"\n'
                    f"date = {date}\nambient_c = {ambient}\n")
    return path


def history_json(capsys, monkeypatch, url: str) -> dict:
    ran = ogacq_here(capsys, monkeypatch, "history", NAME, "--history", url, "--json")
    assert ran.returncode == 0, ran.stderr
    return json.loads(ran.stdout)


@pytest.mark.slow
def test_three_calibrations_drift_flagged_in_sqlite_and_postgresql(tmp_path, capsys,
                                                                   monkeypatch,
                                                                   postgres_url):
    sqlite_path = tmp_path / "site-history.sqlite"
    sessions = []
    for i in range(3):
        ran = ogacq_here(capsys, monkeypatch, "run", campaign(tmp_path / f"cal{i}", i),
                         "--json", "--history", sqlite_path)
        assert ran.returncode == 0, ran.stderr
        assert "history: 1 calibration recorded" in ran.stderr
        sessions.append(tmp_path / f"cal{i}" / "session.jsonl")

    lite = history_json(capsys, monkeypatch, str(sqlite_path))
    found = lite["calibrations"]
    assert len(found) == 3
    # each on its own (rehearsed) date, at its temperature, by its operator
    assert [c["date"][:19] for c in found] == [d for d, _, _ in CALIBRATIONS]
    assert [c["ambient_c"] for c in found] == [a for _, a, _ in CALIBRATIONS]
    assert [c["operator"] for c in found] == ["A. Technician"] * 3
    assert [c["session"]["path"] for c in found] == [str(s) for s in sessions]
    x = [c["parameters"]["joint_offset.x"] for c in found]
    for entry, (_, _, truth) in zip(x, CALIBRATIONS, strict=True):
        assert abs(entry["value_mm"] - truth) < 0.01
        # U from the budget, or the fit's std standing in for it (said in the flag)
        assert (entry["U_mm"] or 2 * entry["std_mm"]) < 0.02
    # the injected drift is flagged. A change is flagged at |E_n| > 1 (U at k = 2), so
    # two campaigns of an unchanged machine are flagged now and then (about 5 % per
    # parameter at most): any other flag is within 2.5 U (5 standard uncertainties)
    injected = ("joint_offset.x", found[1]["record"], found[2]["record"])
    [drift] = [d for d in lite["drifts"] if (d["parameter"], d["from"], d["to"]) == injected]
    assert drift["change_mm"] == pytest.approx(0.079, abs=0.01)
    for other in lite["drifts"]:
        if other is not drift:
            assert abs(other["change_mm"]) < 2.5 * other["U_change_mm"], other

    # the human table says it too
    monkeypatch.setenv("COLUMNS", "250")
    table = ogacq_here(capsys, monkeypatch, "history", NAME, "--history", sqlite_path)
    assert table.returncode == 0 and "! drift: joint_offset.x +0.0" in table.stdout

    # the same sessions into a PostgreSQL history: the same answers
    added = ogacq_here(capsys, monkeypatch, "history", "add", *sessions, "--history",
                       postgres_url)
    assert added.returncode == 0, added.stderr
    assert history_json(capsys, monkeypatch, postgres_url) == lite
    # recorded twice, still once
    again = ogacq_here(capsys, monkeypatch, "history", "add", *sessions, "--history",
                       postgres_url)
    assert again.stdout.count("already recorded") == 3
    assert history_json(capsys, monkeypatch, postgres_url) == lite
