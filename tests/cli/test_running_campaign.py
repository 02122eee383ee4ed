"""Issue 26, measured case 1: ``ogacq diagnose`` of a session that ``ogacq run`` is still
writing stored half the campaign as the machine's calibration, and the complete result
never reached the history. Now the running campaign's lock says it is running, the
diagnosis of what it holds needs --partial and records nothing, and the run records the
complete calibration when it ends.

The run is held mid-way by SIGSTOP (it keeps its lock, as a running campaign does),
so the test does not depend on how fast this machine runs it."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time

from ogacq.cli.app import main
from ogacq.session.store import load_session
from tests.campaign.conftest import write_campaign


def readings_in(path) -> int:
    try:
        return path.read_text().count('"type":"reading"')
    except OSError:
        return 0


def test_diagnose_during_a_run_records_nothing_partial_and_the_run_records_the_whole(
        tmp_path, capsys, ogacq_home):
    path = write_campaign(tmp_path, seed=4, speed=20)
    session, history = tmp_path / "session.jsonl", ogacq_home / "history.sqlite"
    run = subprocess.Popen([sys.executable, "-m", "ogacq", "run", str(path)],
                           stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.monotonic() + 120
        while readings_in(session) < 12 and run.poll() is None and time.monotonic() < deadline:
            time.sleep(0.05)
        os.kill(run.pid, signal.SIGSTOP)
        assert run.poll() is None and readings_in(session) < 72

        capsys.readouterr()
        assert main(["diagnose", str(session)]) == 4
        refused = capsys.readouterr().err
        assert f"the campaign is running: ogacq run {path} (pid {run.pid})" in refused
        assert "--partial" in refused and len(refused.strip().splitlines()) == 1

        assert main(["diagnose", str(session), "--partial", "--json"]) == 0
        said = capsys.readouterr()
        partial = json.loads(said.out)["partial"]
        assert partial["status"] == "running" and partial["planned"] == 72
        assert partial["says"].startswith(f"partial: {partial['readings']} of 72 planned")
        assert "history: nothing recorded: partial" in said.err
        assert not history.exists()  # nothing of the half campaign entered a history
    finally:
        os.kill(run.pid, signal.SIGCONT)
        out, err = run.communicate(timeout=300)
    assert run.returncode == 0, err
    assert "history: 1 calibration recorded" in err

    capsys.readouterr()
    name = load_session(session).header.machine["name"]  # the machine file's own name
    assert main(["history", name, "--history", str(history), "--json"]) == 0
    (calibration,) = json.loads(capsys.readouterr().out)["calibrations"]
    result = load_session(session).result
    for axis in "xyz":  # the complete campaign's result, not the half's
        stored = calibration["parameters"][f"joint_offset.{axis}"]["value_mm"]
        assert abs(stored - result.refit["parameters"]["joint_offset"][axis]) < 1e-9
