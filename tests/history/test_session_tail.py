"""Issue 36.4: a session's completeness proven, not assumed. Every seal holds on a file
cut at a line end, so each writer closes its turn with a ``closed`` record its header
announces, and the history's own count of the session's records finds a cut that lands
exactly after an earlier writer's ``closed`` record. ``session check`` says neither as
"every one as written", and ``history add`` refuses them, a session whose seals were
stripped (an edited reading then passes every check) and a torn one, unless told
(``--accept-unsealed``): its record in the history then says so."""

from __future__ import annotations

import json
import os
import sqlite3
from pathlib import Path

import pytest

from ogacq.session.records import EnvironmentRecord
from ogacq.session.store import SessionWriter, load_session
from tests.writeback.conftest import ogacq_here, synthetic_session

NAME = "OG-tail"
SECOND_TURN = 4  # records a second writer appends before its closed record


@pytest.fixture
def two_turns(tmp_path: Path) -> Path:
    """A finished campaign's session, then a second writer's turn, each closed."""
    campaign = tmp_path / "campaign.toml"
    campaign.write_text("")
    machine = {"leg_length_mm": 310.25, "rho_min_mm": -100.0, "rho_max_mm": 60.0,
               "gauge_resolution_mm": 0.001, "name": NAME}
    path = synthetic_session(tmp_path / "session.jsonl", campaign,
                             offsets_mm={"x": 0.2, "y": -0.1, "z": 0.05},
                             header_extra={"machine": machine})
    with SessionWriter.append_to(path) as writer:
        for k in range(SECOND_TURN):
            writer.write(EnvironmentRecord(stage="end", ambient_c=20.0 + k, source="typed"))
    return path


def cut(path: Path, lines: int, out: Path) -> Path:
    kept = path.read_text(encoding="utf-8").splitlines(keepends=True)[:-lines]
    out.write_text("".join(kept), encoding="utf-8")
    return out


def history_records(home: Path) -> list[dict]:
    with sqlite3.connect(home / "history.sqlite") as db:
        return [json.loads(row[0]) for row in db.execute("SELECT record FROM ogacq_events")]


def test_a_closed_session_is_vouched_for_and_enters_the_history(two_turns, capsys,
                                                                 monkeypatch):
    assert load_session(two_turns).closure.closed
    check = ogacq_here(capsys, monkeypatch, "session", "check", two_turns)
    assert check.returncode == 0 and "every one as written (sealed, closed by its last " \
        "writer)" in check.stdout, check.stdout
    assert ogacq_here(capsys, monkeypatch, "history", "add", two_turns).returncode == 0


@pytest.mark.parametrize("lines", range(1, 7))
def test_a_cut_tail_is_found_and_refused_by_history_add(two_turns, lines, capsys, monkeypatch,
                                                        tmp_path):
    added = ogacq_here(capsys, monkeypatch, "history", "add", two_turns)
    assert added.returncode == 0, added.stderr
    short = cut(two_turns, lines, tmp_path / "cut.jsonl")

    check = ogacq_here(capsys, monkeypatch, "session", "check", short)
    assert check.returncode == 2 and "every one as written" not in check.stdout, check.stdout
    # the second writer's whole turn (its records and its closed record) cut: every seal
    # and the closure hold, and only the history's count finds it
    why = "the history recorded" if lines == SECOND_TURN + 1 else "not closed after line"
    assert why in check.stdout, check.stdout

    refused = ogacq_here(capsys, monkeypatch, "history", "add", short)
    assert refused.returncode == 4 and why in refused.stderr and "--accept-unsealed" in \
        refused.stderr, refused.stderr


def test_a_stripped_seal_and_an_edited_reading_are_refused_unless_accepted(
        two_turns, capsys, monkeypatch, tmp_path):
    lines = [json.loads(line) for line in two_turns.read_text().splitlines()]
    del lines[0]["integrity"], lines[0]["closing"]
    for line in lines:
        for key in ("seq", "prev", "crc"):
            line.pop(key, None)
    reading = next(line for line in lines if line["type"] == "reading")
    reading["reading_mm"] += 0.05
    stripped = tmp_path / "stripped.jsonl"
    stripped.write_text("".join(json.dumps(line) + "\n" for line in lines))

    refused = ogacq_here(capsys, monkeypatch, "history", "add", stripped)
    assert refused.returncode == 4 and "stripped.jsonl:1: unchecked" in refused.stderr, \
        refused.stderr
    assert not (Path(os.environ["OGACQ_HOME"]) / "history.sqlite").exists()  # nothing made

    accepted = ogacq_here(capsys, monkeypatch, "history", "add", stripped, "--accept-unsealed")
    assert accepted.returncode == 0 and "taken as it stands" in accepted.stdout, accepted.stderr
    home = Path(os.environ["OGACQ_HOME"])
    (record,) = [r for r in history_records(home) if r["session"]["path"] == str(stripped)]
    assert record["session"]["integrity"] == "unchecked"
    assert "without the chained seals" in record["session"]["edited"][0]["problem"]


def test_a_torn_session_is_refused_unless_accepted(two_turns, capsys, monkeypatch, tmp_path):
    torn = tmp_path / "torn.jsonl"
    torn.write_bytes(two_turns.read_bytes()[:-20])  # its closed record cut mid-line
    refused = ogacq_here(capsys, monkeypatch, "history", "add", torn)
    assert refused.returncode == 4 and "is a torn record" in refused.stderr, refused.stderr
    accepted = ogacq_here(capsys, monkeypatch, "history", "add", torn, "--accept-unsealed")
    # its lines wrapped at the width: read as one text
    assert accepted.returncode == 0 and "is a torn record" in " ".join(
        accepted.stdout.split()), accepted.stdout
