"""A disk that fills up (or fails) while ogacq writes: the campaign stops the axes and
ends in one line with exit 3, what was recorded stays valid and ``resume`` completes
once there is room; a report is never left half-written.

How the disk fills up without root: the process runs under ``RLIMIT_FSIZE`` with
SIGXFSZ ignored (``tests.cli.helpers.with_file_size_limit``), so every write past
the limit fails with EFBIG in the kernel, as one on a full disk fails with ENOSPC.
The code under test is the real one, in its own process; only the size of the
"disk" is the test's.
"""

from __future__ import annotations

import subprocess
import sys

from ogacq.session.store import load_session
from tests.campaign.conftest import write_campaign
from tests.cli.helpers import with_file_size_limit

FAST = "\n[stability]\nreadings = 2\ntolerance_mm = 0.003\ntimeout_s = 1.0\n"

ATOMIC = """
from ogacq.io.atomic import write_atomically
from ogacq.io.errors import StorageError
try:
    write_atomically(sys.argv[2], b"new" * 100_000)
except StorageError as exc:
    print(exc)
    sys.exit(3)
"""


def test_a_full_disk_mid_campaign_stops_in_one_line_and_resume_completes(tmp_path):
    path = write_campaign(tmp_path, seed=5, extra="cycles = 1\n" + FAST, line_at_speed=True)
    session_path = tmp_path / "session.jsonl"
    # room for the header and some readings (a few hundred bytes each), not for all 24
    ran = with_file_size_limit(6_000, "run", path)
    assert ran.returncode == 3, ran.stderr
    assert "Traceback" not in ran.stderr
    (stopped,) = [line for line in ran.stderr.splitlines() if "campaign stopped" in line]
    assert str(session_path) in stopped and "File too large" in stopped

    on_file = session_path.read_bytes()
    assert len(on_file) <= 6_000 and on_file.endswith(b"\n")  # whole records only
    session = load_session(session_path)
    assert not session.warnings  # nothing torn: the partial record was cut back
    taken = len(session.readings)
    assert 0 < taken < 24

    resumed = subprocess.run([sys.executable, "-m", "ogacq", "resume", session_path, "--json"],
                             capture_output=True, text=True, timeout=120)
    assert resumed.returncode == 0, resumed.stderr
    session = load_session(session_path)
    keys = [(r.step, r.gauge) for r in session.readings]
    assert len(keys) == len(set(keys)) == 24 and session.finished
    assert session_path.read_bytes().startswith(on_file)  # the first part untouched


def test_a_file_replaced_on_a_full_disk_is_left_as_it_was(tmp_path):
    """How ``report`` writes its page and figures: a full disk leaves the old file
    (or none), never a truncated one, and no temporary file behind."""
    target = tmp_path / "figure.png"
    target.write_bytes(b"old")
    ran = with_file_size_limit(50_000, target, body=ATOMIC)
    assert ran.returncode == 3 and "cannot write" in ran.stdout and str(target) in ran.stdout
    assert target.read_bytes() == b"old"
    assert [p.name for p in tmp_path.iterdir()] == ["figure.png"]
    target.unlink()
    ran = with_file_size_limit(50_000, target, body=ATOMIC)
    assert ran.returncode == 3 and list(tmp_path.iterdir()) == []
    assert with_file_size_limit(1_000_000, target, body=ATOMIC).returncode == 0
    assert target.read_bytes() == b"new" * 100_000
