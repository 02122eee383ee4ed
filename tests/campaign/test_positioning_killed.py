"""``ogacq positioning`` killed (SIGKILL, a real process) part-way through its test, then
run again by the same command: every reading before the kill kept once, as it was
read, and the figures those of an uninterrupted test within the scale's noise."""

from __future__ import annotations

import json

from ogacq.cli.app import main
from ogacq.session.records import PositionRecord
from ogacq.session.store import load_session
from tests.campaign.conftest import write_campaign
from tests.campaign.test_resume import kill_after, start
from tests.cli.helpers import with_file_size_limit

LEAD_Y = "[lead_screw.y]\namplitude_mm = 0.004\npitch_mm = 6.35\nphase_deg = 40.0\n"
# The two tests' figures differ by the scale's noise (0.3 µm a value, averaged over a
# settle) and its display step (1 µm): a figure moves by a count at most.
WITHIN_NOISE_MM = 0.0015
KILLED_AT = 23  # readings on disk when the test is killed


def positioning_campaign(folder):
    path = write_campaign(folder, seed=5, speed=200, extra="[axis_scale.y]\n")
    (folder / "effects.toml").write_text(LEAD_Y)
    path.write_text(path.read_text().replace(
        "[simulator]\n", '[simulator]\neffects = "effects.toml"\nline_at_speed = true\n'))
    return path


def positioning_json(capsys, *command) -> dict:
    """``ogacq positioning ... --json`` run here (the killed one runs in a process)."""
    assert main([str(c) for c in command]) == 0
    return json.loads(capsys.readouterr().out.splitlines()[-1])


def test_a_killed_positioning_test_resumes_losing_nothing(tmp_path, capsys):
    reference = positioning_json(capsys, "positioning", positioning_campaign(tmp_path / "ref"),
                                 "--axis", "y", "--runs", "2", "--json")

    campaign = positioning_campaign(tmp_path / "killed")
    session = campaign.parent / "positioning-y.jsonl"
    command = ("positioning", campaign, "--axis", "y", "--runs", "2", "--json")
    kill_after(start(*command), session, KILLED_AT, "position")
    before = [(r.run, r.direction, r.target_mm, r.scale_mm)
              for r in load_session(session).of_type(PositionRecord)]
    assert len(before) >= KILLED_AT and not load_session(session).finished

    resumed = positioning_json(capsys, *command)
    done = load_session(session)
    after = [(r.run, r.direction, r.target_mm, r.scale_mm)
             for r in done.of_type(PositionRecord)]
    assert after[:len(before)] == before  # kept as read, none read again
    keys = [a[:3] for a in after]
    assert len(keys) == len(set(keys)) == 2 * 2 * len(reference["targets_mm"])
    assert done.finished and resumed["targets_mm"] == reference["targets_mm"]
    # R (4 s of a few runs) is too noisy a statistic to compare two tests at 1.5 um
    for name in ("A_mm", "E_mm", "M_mm", "B_mm"):
        assert abs(resumed["iso230_2"][name] - reference["iso230_2"][name]) <= \
            WITHIN_NOISE_MM, (name, resumed["iso230_2"], reference["iso230_2"])
    # the lead's error is what the figures show, not the kill
    assert 0.006 < resumed["iso230_2"]["E_mm"] < 0.010
    assert json.loads(session.with_suffix(".json").read_text()) == resumed


def test_a_full_disk_stops_a_positioning_test_in_one_line_and_it_continues(tmp_path, capsys):
    """The disk full mid-test: the axes stopped, one line, exit 3, whole records on file;
    the same command with room continues it to its end."""
    campaign = positioning_campaign(tmp_path)
    session = tmp_path / "positioning-y.jsonl"
    ran = with_file_size_limit(12_000, "positioning", campaign, "--axis", "y", "--runs", "2")
    assert ran.returncode == 3, ran.stderr
    assert "Traceback" not in ran.stderr and "File too large" in ran.stderr, ran.stderr
    on_file = session.read_bytes()
    assert len(on_file) <= 12_000 and on_file.endswith(b"\n")
    stopped = load_session(session)
    assert not stopped.warnings and len(stopped.of_type(PositionRecord)) > 0
    assert not stopped.finished

    positioning_json(capsys, "positioning", campaign, "--axis", "y", "--runs", "2", "--json")
    done = load_session(session)
    assert done.finished and session.read_bytes().startswith(on_file)
