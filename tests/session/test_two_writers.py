"""Two writers on one session, whichever commands they are (run, resume, the wizard,
offsets write): one holds it, the other is refused in one line naming the holder,
and the session stays valid, without duplicates, with every write-back audited.

Each command meets a session held by another process through the real lock (the
write-back's refusal is proved in ``tests/writeback/test_refusals.py``, against a
real controller); then two real ``ogacq resume`` processes race for one session.
"""

from __future__ import annotations

import subprocess
import sys

import pytest

from ogacq.campaign.campaign_file import read_campaign
from ogacq.campaign.run import run_campaign
from ogacq.protocol.runner import CampaignStopped, Progress
from ogacq.session.records import EndRecord
from ogacq.session.store import load_session
from tests.campaign.conftest import write_campaign
from tests.writeback.conftest import ogacq_here

FAST = "cycles = 1\n\n[stability]\nreadings = 2\ntolerance_mm = 0.003\ntimeout_s = 1.0\n"

HOLD = """
import sys, time
from ogacq.session.store import SessionWriter
writer = SessionWriter.append_to(sys.argv[1])
print("holding", flush=True)
time.sleep(60)
"""


def interrupted_campaign(folder):
    """A campaign stopped by Ctrl-C after 8 of its 24 readings."""
    campaign = read_campaign(write_campaign(folder, seed=9, extra=FAST))

    def observer(progress: Progress) -> None:
        if progress.done == 8:
            raise KeyboardInterrupt

    with pytest.raises(CampaignStopped):
        run_campaign(campaign, observer=observer)
    return campaign


def assert_intact(session_path, readings: int) -> None:
    session = load_session(session_path)  # valid: checksums, sequence, no torn record
    keys = [(r.step, r.gauge) for r in session.readings]
    assert len(keys) == len(set(keys)) == readings
    assert not session.warnings


def test_every_command_refuses_a_session_another_process_writes(tmp_path, capsys,
                                                                monkeypatch):
    campaign = interrupted_campaign(tmp_path)
    before = campaign.session.read_bytes()
    holder = subprocess.Popen([sys.executable, "-c", HOLD, str(campaign.session)],
                              stdout=subprocess.PIPE, text=True)
    try:
        assert holder.stdout.readline().strip() == "holding"
        tried = {
            "resume": ogacq_here(capsys, monkeypatch, "resume", campaign.session),
            "wizard": ogacq_here(capsys, monkeypatch, "wizard", "--resume", campaign.session),
        }
        # a second `run` of the campaign would start the same session anew
        tried["run"] = ogacq_here(capsys, monkeypatch, "run", campaign.path)
    finally:
        holder.kill()
        holder.wait()
    for command, ran in tried.items():
        assert ran.returncode == 2, (command, ran.stderr)
        assert "Traceback" not in ran.stderr
        (error,) = [line for line in ran.stderr.splitlines() if "ogacq: error" in line]
        if command == "run":
            assert "a session already exists here" in error
        else:
            assert "in use by" in error and f"pid {holder.pid}" in error, command
    assert campaign.session.read_bytes() == before
    assert_intact(campaign.session, 8)


def test_two_resumes_racing_for_one_session_leave_it_whole(tmp_path):
    campaign = interrupted_campaign(tmp_path)
    racers = [subprocess.Popen([sys.executable, "-m", "ogacq", "resume", str(campaign.session),
                                "--json"], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                               text=True) for _ in range(2)]
    results = [(racer.wait(timeout=120), racer.stderr.read()) for racer in racers]
    for racer in racers:
        racer.stdout.close()
        racer.stderr.close()
    codes = sorted(code for code, _ in results)
    assert codes == [0, 2], results
    (refusal,) = [err for code, err in results if code == 2]
    assert "Traceback" not in refusal
    assert any(why in refusal for why in ("in use by", "was written to since it was read",
                                          "nothing to resume")), refusal
    assert_intact(campaign.session, 24)
    ends = [r.status for r in load_session(campaign.session).of_type(EndRecord)]
    assert ends == ["interrupted", "complete"]
