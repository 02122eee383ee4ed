"""One lock per controller endpoint and per maps file: a process that has the
controller open (a campaign, through the same ``open_controller``) keeps ``offsets
write`` of another session from re-homing it and ``maps restore`` from replacing the
maps it applies; the refusal names the holder; the lock goes with the process, even
killed. (The lock was per session: both went through.)"""

from __future__ import annotations

import contextlib
import signal
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

from ogacq.model.parameters import AXES
from ogacq.session.store import load_session
from ogacq.writeback.audit import AuditLog
from ogacq.writeback.maps import MapsFile
from ogacq.writeback.maps_table import maps_checksum, read_maps_table
from tests.compensation.maps import screw_map
from tests.writeback.conftest import ogacq_here, sim_campaign, simulator, synthetic_session

HOLD = """
import sys
from ogacq.campaign.campaign_file import read_campaign
from ogacq.campaign.station import open_controller
with open_controller(read_campaign(sys.argv[1]).controller):
    print("held", flush=True)
    sys.stdin.read()
"""


@contextlib.contextmanager
def held_elsewhere(campaign: Path) -> Iterator[subprocess.Popen]:
    """Another process with the campaign's controller open, as a running campaign has
    it, until it is told to stop (or killed)."""
    proc = subprocess.Popen([sys.executable, "-c", HOLD, str(campaign)], stdin=subprocess.PIPE,
                            stdout=subprocess.PIPE, text=True)
    try:
        assert proc.stdout is not None and proc.stdout.readline().strip() == "held"
        yield proc
    finally:
        if proc.poll() is None:
            proc.kill()
        proc.wait()


def test_a_controller_in_use_refuses_writes_and_maps_restores_naming_the_holder(
        tmp_path, capsys, monkeypatch):
    with simulator(tmp_path, "cia402", 3) as info:
        campaign = sim_campaign(tmp_path, info, name="c")
        campaign.write_text(campaign.read_text().replace(
            "[controller]\n", '[controller]\nmaps_file = "maps.json"\n', 1))
        session = synthetic_session(tmp_path / "s.jsonl", campaign,
                                    offsets_mm=dict.fromkeys(AXES, 0.2))
        maps = MapsFile(tmp_path / "maps.json")
        with AuditLog(load_session(session)) as audit:
            maps.execute(maps.plan_write({"x": screw_map("x")}, in_force_checksum=None),
                         audit, "--yes")
        written = maps.held()
        with held_elsewhere(campaign) as holder:
            write = ogacq_here(capsys, monkeypatch, "offsets", "write", session, "--yes",
                               "--history", "none")
            assert write.returncode == 2, write.stderr
            assert "in use by" in write.stderr and f"pid {holder.pid}" in write.stderr
            back = ogacq_here(capsys, monkeypatch, "maps", "restore", session, "--yes",
                              "--history", "none")
            assert back.returncode == 2 and f"pid {holder.pid}" in back.stderr, back.stderr
            assert maps.held() == written  # nothing replaced under the running campaign
            holder.send_signal(signal.SIGKILL)  # the lock goes with the process
            holder.wait()
        back = ogacq_here(capsys, monkeypatch, "maps", "restore", session, "--yes",
                          "--history", "none")
        assert back.returncode == 0, back.stderr
        assert read_maps_table(tmp_path / "maps.json").checksum == maps_checksum({})
        write = ogacq_here(capsys, monkeypatch, "offsets", "write", session, "--yes",
                           "--history", "none")
        assert "in use by" not in write.stderr
