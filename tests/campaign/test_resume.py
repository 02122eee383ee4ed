"""A campaign killed at random points loses nothing and ends as an uninterrupted one."""

import os
import signal
import subprocess
import sys
import time

import numpy as np

from ogacq.session.records import GaugesSetRecord, ResumeRecord
from ogacq.session.store import load_session
from tests.campaign.conftest import write_campaign
from tests.cli.helpers import run_ogacq
from tests.interrupts import sigint_as_at_a_terminal

# What one reading off by one display count (1 um) moves an offset in the papers'
# 72-reading campaign: about a quarter of a micrometre.
ONE_COUNT_IN_THE_FIT_MM = 3e-4


def readings_on_disk(path, record_type: str = "reading") -> int:
    if not path.exists():
        return 0
    return path.read_bytes().count(b'"type":"%s"' % record_type.encode())


def start(*args):
    with sigint_as_at_a_terminal():  # a Ctrl-C reaches it in a suite run in background
        return subprocess.Popen([sys.executable, "-m", "ogacq", *map(str, args)],
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                start_new_session=True)


def kill_after(proc, session, n_readings, record_type="reading", timeout_s=300.0):
    """SIGKILL the process group once ``n_readings`` records of ``record_type`` are on
    disk (the deadline only ends a run that never gets there)."""
    end = time.monotonic() + timeout_s
    while readings_on_disk(session, record_type) < n_readings:
        assert proc.poll() is None, proc.stderr.read().decode()
        assert time.monotonic() < end, f"{n_readings} {record_type} records not reached"
        time.sleep(0.005)
    os.killpg(proc.pid, signal.SIGKILL)
    proc.wait(10)


def offsets(out):
    return np.array([out["parameters"]["joint_offset"][a] for a in "xyz"])


def test_sigkill_at_random_points_then_resume(tmp_path):
    rng = np.random.default_rng(int.from_bytes(os.urandom(4), "little"))
    # noise-free gauges make both runs' readings identical, so results can be compared exactly
    reference = run_ogacq("run", write_campaign(tmp_path / "ref", seed=9, noise=0.0), "--json",
                          check_json=True)

    path = write_campaign(tmp_path / "killed", seed=9, noise=0.0)
    session = path.parent / "session.jsonl"
    # 3 readings apart at least: the two gauges of a posture, read at once, land together
    kill_points = sorted(rng.choice(np.arange(2, 70, 3), size=3, replace=False))
    kill_after(start("run", path), session, kill_points[0])
    for point in kill_points[1:]:
        kill_after(start("resume", session), session, point)
    final = run_ogacq("resume", session, "--json", check_json=True)

    loaded = load_session(session)
    keys = [(r.step, r.gauge.key) for r in loaded.readings]
    assert len(keys) == 72, f"killed at {kill_points}"
    assert len(set(keys)) == 72, "a reading was taken twice"
    assert loaded.finished
    assert len(loaded.of_type(ResumeRecord)) == 3
    # The same as uninterrupted, up to the simulated machine's timing: a value at a
    # display step's edge can read one count either side (a third of the fit's std).
    assert np.allclose(offsets(final), offsets(reference), atol=ONE_COUNT_IN_THE_FIT_MM), \
        kill_points


def test_ctrl_c_names_the_command_that_continues_the_session(tmp_path):
    # real time: the settling alone (0.5 s at each of its 36 reading steps) keeps the
    # campaign running long after its first reading, so the Ctrl-C lands in it however
    # late a busy machine lets this test send it (at speed 5 it once came after the end)
    path = write_campaign(tmp_path / "c", seed=9, speed=1)
    session = path.parent / "session.jsonl"
    proc = start("run", path)
    end = time.monotonic() + 60
    while readings_on_disk(session) < 1:
        assert proc.poll() is None and time.monotonic() < end, proc.stderr.read().decode()
        time.sleep(0.01)
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=30)
    assert proc.returncode == 130, err
    assert f"continue it with `ogacq resume {session}`" in err.decode()


def test_torn_last_record_loads_with_a_warning_and_resumes(tmp_path):
    path = write_campaign(tmp_path / "torn", seed=4, noise=0.0)
    session = path.parent / "session.jsonl"
    kill_after(start("run", path), session, 30)
    raw = session.read_bytes()
    cut = raw.rstrip(b"\n")
    last_start = cut.rfind(b"\n") + 1
    session.write_bytes(cut[: last_start + (len(cut) - last_start) // 2])  # half a record
    loaded = load_session(session)
    assert len(loaded.warnings) == 1
    assert "torn last record" in loaded.warnings[0]
    assert f"{session}:" in loaded.warnings[0]
    refit = run_ogacq("refit", session, "--machine", path.parent / "machine.toml")
    assert refit.returncode == 4 and "partial: " in refit.stderr  # killed: not finished
    refit = run_ogacq("refit", session, "--machine", path.parent / "machine.toml", "--partial")
    assert refit.returncode == 0
    assert "torn last record" in refit.stderr and "partial: " in refit.stdout
    final = run_ogacq("resume", session, "--json", check_json=True)
    assert final["dof"] > 0
    loaded = load_session(session)
    assert loaded.finished and not loaded.warnings
    assert len({(r.step, r.gauge.key) for r in loaded.readings}) == len(loaded.readings) == 72


def test_a_complete_campaign_is_not_resumed(tmp_path):
    path = write_campaign(tmp_path / "done", seed=2, speed=100)
    run_ogacq("run", path, "--json", check_json=True)
    proc = run_ogacq("resume", path.parent / "session.jsonl")
    assert proc.returncode == 2 and "complete" in proc.stderr


def test_moved_indicators_resume_on_the_leg_they_were_on(tmp_path):
    """Killed half way through the y leg: the resumed campaign finds the indicators on
    the y leg (where the operator left them) and ends as an uninterrupted run."""
    def moved(folder):
        path = write_campaign(folder, seed=17, noise=0.0)
        path.write_text(path.read_text().replace("[simulator]\n",
                                                 '[simulator]\ngauge_layout = "moved"\n'))
        return path

    reference = run_ogacq("run", moved(tmp_path / "ref"), "--json", check_json=True)
    path = moved(tmp_path / "killed")
    session = path.parent / "session.jsonl"
    kill_after(start("run", path), session, 36)  # the y leg has readings 25..48
    final = run_ogacq("resume", session, "--json", check_json=True)
    loaded = load_session(session)
    assert len({(r.step, r.gauge.key) for r in loaded.readings}) == len(loaded.readings) == 72
    assert [e.leg for e in loaded.of_type(GaugesSetRecord)] == ["x", "y", "z"]
    assert np.allclose(offsets(final), offsets(reference), atol=ONE_COUNT_IN_THE_FIT_MM)
