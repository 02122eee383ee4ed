"""Unreliable results are refused with the reason and write nothing (the controller is
read back to prove it); ``--force`` writes past the reasons and records them; the
checks that need no controller come before connecting to one."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

from ogacq.model.parameters import AXES
from ogacq.session.records import OffsetsRecord
from ogacq.session.store import load_session
from tests.campaign.conftest import MACHINE
from tests.cli.helpers import with_file_size_limit
from tests.writeback.conftest import (
    controller_offsets,
    ogacq,
    ogacq_here,
    sim_campaign,
    simulator,
    synthetic_session,
)

ZEROS = dict.fromkeys(AXES, 0.0)
OFFSETS = {"x": 0.8, "y": -0.6, "z": 1.2}


@pytest.fixture(scope="module")
def station(tmp_path_factory):
    """One CiA 402 ``ogacq sim`` for the module, and a campaign file naming it."""
    folder = tmp_path_factory.mktemp("refusals")
    with simulator(folder, "cia402", seed=4) as info:
        yield sim_campaign(folder, info, name="campaign")


@pytest.fixture
def campaign(station):
    assert controller_offsets(station) == ZEROS  # every test starts from a clean drive
    return station


def refused_and_untouched(ran, session_path, campaign, code: str) -> None:
    assert ran.returncode == 4, ran.stdout + ran.stderr
    assert f"refused ({code})" in ran.stderr
    assert "nothing written" in ran.stderr
    assert controller_offsets(campaign) == ZEROS
    records = load_session(session_path).of_type(OffsetsRecord)
    assert [r.stage for r in records] == ["refused"]
    assert code in records[0].details["codes"]


@pytest.mark.parametrize(("code", "session_kw", "options", "words"), [
    # one leg seen from Zero and Max only: two combinations of three offsets
    ("unidentifiable", {"legs": (0,), "postures": ("zero", "max", "zero")}, (),
     "not identifiable"),
    # the machine is out of square by 1 mrad: offsets alone cannot fit the readings
    ("inconsistent", {"effects": {"squareness.xy": 1.0}}, (), "NOT within the gauge noise"),
    ("too_large", {}, ("--max-change-mm", "1.0"), "exceed the 1 mm limit"),
    # one reading 2 mm off: the noise measured from the repeats swells until the offsets
    # alone pass, and only the reading's distance from its agreeing repeats tells
    ("outlier", {"slip": (33, 2.0)}, (), "far from its repeats, which agree"),
])
def test_unreliable_result_is_refused_and_nothing_written(
        tmp_path, capsys, monkeypatch, campaign, code, session_kw, options, words):
    session = synthetic_session(tmp_path / "s.jsonl", campaign, offsets_mm=OFFSETS,
                                **session_kw)
    ran = ogacq_here(capsys, monkeypatch, "offsets", "write", session, "--yes", *options)
    refused_and_untouched(ran, session, campaign, code)
    assert words in ran.stderr


def test_refusal_exit_code_from_the_real_process(tmp_path, campaign):
    session = synthetic_session(tmp_path / "s.jsonl", campaign, offsets_mm=OFFSETS,
                                effects={"squareness.xy": 1.0})
    ran = ogacq("offsets", "write", session, "--yes")
    refused_and_untouched(ran, session, campaign, "inconsistent")
    assert "ogacq diagnose" in ran.stderr and "Traceback" not in ran.stderr


def test_show_says_why_it_would_refuse_and_writes_nothing(tmp_path, capsys, monkeypatch,
                                                          campaign):
    session = synthetic_session(tmp_path / "s.jsonl", campaign, offsets_mm=OFFSETS,
                                effects={"squareness.xy": 1.0})
    ran = ogacq_here(capsys, monkeypatch, "offsets", "show", session, "--json")
    assert ran.returncode == 0, ran.stderr
    shown = json.loads(ran.stdout)
    assert not shown["evidence"]["verdict"]["consistent"]
    assert shown["evidence"]["verdict"]["chi2_dof"] > 10
    assert [r["code"] for r in shown["plan"]["refusals"]] == ["inconsistent"]
    identified = shown["evidence"]["identified_mm"]  # biased by the squareness
    assert shown["plan"]["new_mm"] == pytest.approx({a: -v for a, v in identified.items()},
                                                    abs=0.005)
    monkeypatch.setenv("COLUMNS", "80")
    human = ogacq_here(capsys, monkeypatch, "offsets", "show", session)
    assert "would refuse (inconsistent)" in human.stdout
    # the refusal, its last lines, wrapped between words (it was one line of 300)
    assert [line for line in human.stdout.splitlines() if len(line) > 80] == []
    assert controller_offsets(campaign) == ZEROS
    assert load_session(session).of_type(OffsetsRecord) == []


def test_the_diagnosis_model_offsets_are_written_and_the_squareness_named(
        tmp_path, capsys, monkeypatch, campaign):
    """Out of square by 0.5 mrad: the offsets alone are refused; the diagnosis explains
    the readings with the squareness, and its model's offsets (near the truth, where
    the offsets-only ones are biased) are written, the squareness said to remain."""
    session = synthetic_session(tmp_path / "s.jsonl", campaign, offsets_mm=OFFSETS,
                                effects={"squareness.xy": 0.5})
    plain = ogacq_here(capsys, monkeypatch, "offsets", "write", session, "--yes")
    assert plain.returncode == 4 and "--from-diagnosis" in plain.stderr
    ran = ogacq_here(capsys, monkeypatch, "offsets", "write", session, "--yes",
                     "--from-diagnosis")
    assert ran.returncode == 0, ran.stdout + ran.stderr
    text = " ".join(ran.stdout.split())
    assert "diagnosis: joint offsets with squareness.xy fit: within the gauge noise" in text
    assert "the controller cannot compensate that effect" in text
    held = controller_offsets(campaign)
    assert held == pytest.approx({a: -v for a, v in OFFSETS.items()}, abs=0.006)
    intent = load_session(session).of_type(OffsetsRecord)[-2]
    assert intent.stage == "intent"
    undone = ogacq_here(capsys, monkeypatch, "offsets", "restore", session, "--yes")
    assert undone.returncode == 0 and controller_offsets(campaign) == ZEROS


HOLD_SESSION = """
import sys, time
from ogacq.session.store import SessionWriter
writer = SessionWriter.append_to(sys.argv[1])
print("holding", flush=True)
time.sleep(60)
"""


def test_a_write_back_while_another_command_writes_the_session_is_refused(tmp_path, campaign):
    """A campaign (here: any writer in another process) holds the session: the
    write-back is refused in one line naming it, and nothing reaches the controller
    or the session."""
    session = synthetic_session(tmp_path / "s.jsonl", campaign, offsets_mm=OFFSETS)
    before = session.read_bytes()
    holder = subprocess.Popen([sys.executable, "-c", HOLD_SESSION, str(session)],
                              stdout=subprocess.PIPE, text=True)
    try:
        assert holder.stdout.readline().strip() == "holding"
        ran = ogacq("offsets", "write", session, "--yes")
    finally:
        holder.kill()
        holder.wait()
    assert ran.returncode == 2, ran.stdout + ran.stderr
    assert "in use by" in ran.stderr and f"pid {holder.pid}" in ran.stderr
    assert "Traceback" not in ran.stderr
    assert controller_offsets(campaign) == ZEROS
    assert session.read_bytes() == before


def test_force_writes_past_the_reason_saves_nvm_and_restore_undoes_it(
        tmp_path, capsys, monkeypatch, campaign):
    session = synthetic_session(tmp_path / "s.jsonl", campaign, offsets_mm=OFFSETS)
    ran = ogacq_here(capsys, monkeypatch, "offsets", "write", session, "--yes", "--force",
                     "--max-change-mm", "1.0", "--save-nvm")
    assert ran.returncode == 0, ran.stdout + ran.stderr
    assert "--force writes past" in ran.stderr and "too_large" not in ran.stdout
    held = controller_offsets(campaign)
    assert held == pytest.approx({a: -v for a, v in OFFSETS.items()}, abs=0.006)
    intent, done = load_session(session).of_type(OffsetsRecord)
    assert intent.details["forced"] == ["too_large"] and intent.details["save_nvm"]
    assert done.details["nvm_saved"] and done.details["rehomed"]

    # restoring without --save-nvm is allowed, and says the NVM still holds the new ones
    undone = ogacq_here(capsys, monkeypatch, "offsets", "restore", session, "--yes")
    assert undone.returncode == 0, undone.stdout + undone.stderr
    assert "non-volatile memory" in undone.stdout
    assert controller_offsets(campaign) == ZEROS
    # and again: nothing left to do
    again = ogacq_here(capsys, monkeypatch, "offsets", "restore", session, "--yes")
    assert again.returncode == 0 and "nothing to restore" in again.stdout


def test_restore_refuses_to_undo_a_later_change(tmp_path, capsys, monkeypatch, campaign):
    session = synthetic_session(tmp_path / "s.jsonl", campaign, offsets_mm=OFFSETS)
    assert ogacq_here(capsys, monkeypatch, "offsets", "write", session, "--yes").returncode == 0
    other = synthetic_session(tmp_path / "other.jsonl", campaign, seed=5,
                              offsets_mm={"x": 0.1, "y": 0.1, "z": 0.1},
                              in_force_mm=controller_offsets(campaign))
    assert ogacq_here(capsys, monkeypatch, "offsets", "write", other, "--yes").returncode == 0
    later = controller_offsets(campaign)
    stale = ogacq_here(capsys, monkeypatch, "offsets", "restore", session, "--yes")
    assert stale.returncode == 4 and "refused (stale)" in stale.stderr
    assert controller_offsets(campaign) == later
    # undo in order: the later write-back first, then the first one
    for path in (other, session):
        ran = ogacq_here(capsys, monkeypatch, "offsets", "restore", path, "--yes")
        assert ran.returncode == 0, ran.stdout + ran.stderr
    assert controller_offsets(campaign) == ZEROS


def test_checks_before_connecting(tmp_path, capsys, monkeypatch):
    """No controller needed: a simulator campaign, an IAI campaign without its offset
    table, --save-nvm on IAI, a session with nothing to restore."""
    (tmp_path / "machine.toml").write_text(MACHINE)
    gauges = "".join(f'[[gauges]]\ngauge = "{k}"\nprotocol = "mitutoyo-01a"\n'
                     f'port = "/dev/ttyUSB{n}"\n'
                     for n, k in enumerate(("y_x", "z_x", "x_y", "z_y", "x_z", "y_z")))
    head = 'machine = "machine.toml"\n'
    simulated = tmp_path / "simulated.toml"
    simulated.write_text(head + '[simulator]\nseed = 1\n')
    iai = tmp_path / "iai.toml"
    iai.write_text(head + '[controller]\nprofile = "iai-pcon"\nport = "/dev/nowhere"\n' + gauges)
    iai_table = tmp_path / "iai-table.toml"
    iai_table.write_text(head + '[controller]\nprofile = "iai-pcon"\nport = "/dev/nowhere"\n'
                         'offsets_file = "offsets.toml"\n' + gauges)
    cases = [
        (simulated, (), "does not outlive it"),
        (iai, (), "add offsets_file"),
        (iai_table, ("--save-nvm",), "no non-volatile memory"),
    ]
    for campaign_path, options, words in cases:
        session = synthetic_session(tmp_path / f"{campaign_path.stem}.jsonl", campaign_path,
                                    offsets_mm=OFFSETS, profile="iai-pcon")
        ran = ogacq_here(capsys, monkeypatch, "offsets", "write", session, "--yes", *options)
        assert ran.returncode == 2, (campaign_path, ran.stdout + ran.stderr)
        assert words in ran.stderr and len(ran.stderr.strip().splitlines()) == 1
        assert not (tmp_path / "offsets.toml").exists()
    nothing = ogacq_here(capsys, monkeypatch, "offsets", "restore", tmp_path / "iai.jsonl")
    assert nothing.returncode == 2 and "no write-back is recorded" in nothing.stderr


def test_a_full_disk_refuses_the_write_back_before_the_controller(tmp_path, campaign):
    """The intent record (the old values, what restore needs) cannot be written: the
    write-back is refused in one line and the controller keeps its offsets."""
    session = synthetic_session(tmp_path / "s.jsonl", campaign, offsets_mm=OFFSETS)
    before = session.read_bytes()
    ran = with_file_size_limit(len(before) + 50, "offsets", "write", session, "--yes")
    assert ran.returncode == 3, ran.stdout + ran.stderr
    (error,) = [line for line in ran.stderr.splitlines() if line.startswith("ogacq: error")]
    assert str(session) in error and "nothing was written to the controller" in error
    assert "Traceback" not in ran.stderr
    assert controller_offsets(campaign) == ZEROS
    assert session.read_bytes() == before


def test_a_done_record_the_disk_refuses_ends_in_one_line_and_restore_undoes(
        tmp_path, capsys, monkeypatch, campaign):
    """Room for the intent record (about 430 bytes) but not for the done record after
    it: the controller was written and read back; one line says so, the session ends
    with the whole intent record (no torn one), and restore puts the old values back."""
    session = synthetic_session(tmp_path / "s.jsonl", campaign, offsets_mm=OFFSETS)
    before = session.read_bytes()
    ran = with_file_size_limit(len(before) + 530, "offsets", "write", session, "--yes")
    assert ran.returncode == 3, ran.stdout + ran.stderr
    (error,) = [line for line in ran.stderr.splitlines() if line.startswith("ogacq: error")]
    assert "the session could not record it" in error and "Traceback" not in ran.stderr
    assert controller_offsets(campaign) == pytest.approx(
        {a: -v for a, v in OFFSETS.items()}, abs=0.006)
    loaded = load_session(session)
    assert not loaded.warnings and [r.stage for r in loaded.of_type(OffsetsRecord)] == ["intent"]
    undone = ogacq_here(capsys, monkeypatch, "offsets", "restore", session, "--yes")
    assert undone.returncode == 0, undone.stdout + undone.stderr
    assert controller_offsets(campaign) == ZEROS
