"""Issue 36.5: a kill in ``ogacq calibrate``'s first seconds, before its log has its
header, left a folder holding the simulator's machine file (and a write's temporary,
or an empty log) that neither ``--resume`` nor the same ``--out`` accepted. The same
command starts again in it; ``--resume`` says so in one line; a folder holding
anything else is still refused. The procedure itself is replaced by one that records
the setup it was given: what is tested is the folder's hand-over, not a calibration."""

from __future__ import annotations

from pathlib import Path

import pytest

from ogacq.calibration.log import LOG_NAME, ProcedureLog
from ogacq.cli.calibrate_cmd import _simulator_files
from tests.writeback.conftest import ogacq_here

SEED = 7
EFFECTS = "[joint_offset]\nx = 0.2\n"


@pytest.fixture
def effects(tmp_path: Path) -> Path:
    path = tmp_path / "effects-given.toml"
    path.write_text(EFFECTS)
    return path


def killed_at_start_up(folder: Path, effects: Path) -> None:
    """What a kill after the machine file and during the effects copy leaves."""
    folder.mkdir()
    files = _simulator_files(SEED, effects)
    (folder / "machine.toml").write_bytes(files["machine.toml"])
    (folder / ".effects.toml.k2j3h4.tmp").write_bytes(files["effects.toml"][:5])
    (folder / LOG_NAME).write_bytes(b"")  # created, killed before its header


def test_the_same_command_starts_again_where_a_start_up_kill_left(tmp_path, capsys,
                                                                  monkeypatch, started,
                                                                  effects):
    folder = tmp_path / "run"
    killed_at_start_up(folder, effects)
    ran = ogacq_here(capsys, monkeypatch, "calibrate", "--simulator", "--seed", SEED,
                     "--effects", effects, "--out", folder, "--yes", "--history", "none")
    assert ran.returncode == 4 and "stopped by the test" in ran.stderr, ran.stderr
    (setup, resume), = started
    assert not resume and setup.folder == folder and setup.simulator.seed == SEED
    assert sorted(p.name for p in folder.iterdir()) == ["effects.toml", "machine.toml"]
    assert (folder / "effects.toml").read_text() == EFFECTS


def test_resume_of_a_folder_killed_before_its_log_says_what_to_do(tmp_path, capsys,
                                                                   monkeypatch, started,
                                                                   effects):
    folder = tmp_path / "run"
    killed_at_start_up(folder, effects)
    ran = ogacq_here(capsys, monkeypatch, "calibrate", "--resume", folder, "--yes")
    assert ran.returncode == 2 and len(ran.stderr.strip().splitlines()) == 1, ran.stderr
    assert "stopped before it started" in ran.stderr and f"--out {folder}" in ran.stderr
    assert not started


def test_a_log_with_its_header_alone_is_resumed(tmp_path, capsys, monkeypatch, started,
                                                 effects):
    folder = tmp_path / "run"
    ogacq_here(capsys, monkeypatch, "calibrate", "--simulator", "--seed", SEED, "--effects",
               effects, "--out", folder, "--yes", "--history", "none")
    (setup, _), = started
    ProcedureLog.create(folder, setup.describe()).close()  # killed before its first step
    for args in (["--resume", folder], ["--simulator", "--seed", SEED, "--out", folder]):
        ran = ogacq_here(capsys, monkeypatch, "calibrate", *args, "--yes", "--history", "none")
        assert ran.returncode == 4 and "stopped by the test" in ran.stderr, ran.stderr
        assert started[-1][1] is True  # resumed


def test_a_folder_holding_anything_else_is_still_refused(tmp_path, capsys, monkeypatch,
                                                         started):
    folder = tmp_path / "run"
    folder.mkdir()
    (folder / "machine.toml").write_text("# the shop's own machine file\n")
    ran = ogacq_here(capsys, monkeypatch, "calibrate", "--simulator", "--seed", SEED, "--out",
                     folder, "--yes", "--history", "none")
    assert ran.returncode == 2 and "exists and is not empty" in ran.stderr, ran.stderr
    assert (folder / "machine.toml").read_text() == "# the shop's own machine file\n"
    assert not started
