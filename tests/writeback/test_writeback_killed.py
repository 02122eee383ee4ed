"""``ogacq offsets write`` killed (SIGKILL) after the controller took the new offsets and
before the audit's ``done`` record (tests/calibration/interrupt.py), against an ``ogacq
sim`` process that keeps them: the same command again finds them held, says so, and
records the write done, read back; the audit and the history had it 'interrupted',
the offsets in force unknown to both."""

from __future__ import annotations

import signal
import subprocess
import sys

from ogacq.history.recording import writebacks_of
from ogacq.model.parameters import AXES
from ogacq.session.store import load_session
from tests.writeback.conftest import (
    controller_offsets,
    ogacq_here,
    sim_campaign,
    simulator,
    synthetic_session,
)

OFFSETS = {"x": 0.8, "y": -0.6, "z": 1.2}


def test_a_write_killed_before_its_record_is_found_in_force(tmp_path, capsys, monkeypatch):
    with simulator(tmp_path, "cia402", 3) as info:
        campaign = sim_campaign(tmp_path, info, name="c")
        session = synthetic_session(tmp_path / "s.jsonl", campaign, offsets_mm=OFFSETS)
        killed = subprocess.run(
            [sys.executable, "-m", "tests.calibration.interrupt", "offsets-done", "--",
             "offsets", "write", str(session), "--yes", "--history", "none"],
            capture_output=True, text=True, timeout=120)
        assert killed.returncode == -signal.SIGKILL, killed.stderr
        held = controller_offsets(campaign)
        assert held != dict.fromkeys(AXES, 0.0)
        assert [w.status for w in writebacks_of(load_session(session))] == ["interrupted"]
        again = ogacq_here(capsys, monkeypatch, "offsets", "write", session, "--yes",
                           "--history", "none")
        assert again.returncode == 0, again.stderr
        assert "already holds these offsets" in again.stdout
        (write,) = writebacks_of(load_session(session))
        assert write.status == "done" and write.new_mm == held
