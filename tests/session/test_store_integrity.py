"""Sessions nobody can corrupt: one writer at a time across processes, records that
prove themselves (sequence and checksum), and a fault matrix of truncations, byte
flips, duplicated lines and renamed keys with no traceback and no silent change."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

from ogacq.io.errors import InputError
from ogacq.session.records import EndRecord, ReadingRecord, SalvageRecord
from ogacq.session.store import (
    SessionEdited,
    SessionWriter,
    load_session,
    salvage_session,
    scan_session,
)
from tests.cli.helpers import run_ogacq


def reading(k: int) -> dict:
    return {"step": f"x/c1/p{k}", "gauge": "y_x", "leg": "x", "gauge_axis": "y", "cycle": 1,
            "t_s": 1.5 * k, "q_mm": [0.1 * k, 0.0, 0.0], "tcp_mm": [0.0, 0.0, 0.0],
            "approach": [1, 0, 0], "reading_mm": 5.0 + 0.001 * k}


def make_session(path, n: int = 8):
    with SessionWriter.create(path, {"machine": {}, "plan": None}) as writer:
        for k in range(n):
            writer.write(ReadingRecord.from_json(reading(k)))
    return path


def killed(path) -> bytes:
    """The session as its writer left it had it been killed before closing it: without
    its last line, the ``closed`` record."""
    raw = path.read_bytes()
    return raw[:raw.rstrip(b"\n").rfind(b"\n") + 1]


def values(path) -> list[float]:
    return [r.reading_mm for r in load_session(path).readings]


HOLD = """
import sys, time
from ogacq.session.store import SessionWriter
from ogacq.session.records import EndRecord, ReadingRecord
w = SessionWriter.append_to(sys.argv[1])
print("holding", flush=True)
time.sleep(60)
"""


def test_one_writer_at_a_time_across_processes(tmp_path):
    path = make_session(tmp_path / "s.jsonl")
    holder = subprocess.Popen([sys.executable, "-c", HOLD, str(path)], stdout=subprocess.PIPE,
                              text=True)
    try:
        assert holder.stdout.readline().strip() == "holding"
        with pytest.raises(InputError, match=r"in use by ogacq .*\(pid \d+\).*one writer"):
            SessionWriter.append_to(path)
        assert values(path) == [5.0 + 0.001 * k for k in range(8)]  # readers still read
    finally:
        holder.kill()
        holder.wait()
    with SessionWriter.append_to(path) as writer:  # the lock died with its holder
        writer.write(ReadingRecord.from_json(reading(8)))
    assert len(values(path)) == 9


def test_a_session_written_to_since_it_was_read_is_not_continued(tmp_path):
    path = make_session(tmp_path / "s.jsonl")
    loaded = load_session(path)
    with SessionWriter.append_to(path) as other:
        other.write(ReadingRecord.from_json(reading(8)))
    with pytest.raises(InputError, match="written to since it was read"):
        SessionWriter.reopen(loaded)


def test_a_complete_last_record_without_its_newline_is_kept(tmp_path):
    path = make_session(tmp_path / "s.jsonl")
    path.write_bytes(path.read_bytes().rstrip(b"\n"))
    assert len(values(path)) == 8 and not load_session(path).warnings
    with SessionWriter.append_to(path) as writer:
        writer.write(EndRecord(status="complete"))
    session = load_session(path)
    assert len(session.readings) == 8 and session.finished


def test_a_torn_last_record_is_dropped_with_a_warning_and_cut_before_appending(tmp_path):
    path = make_session(tmp_path / "s.jsonl")
    raw = killed(path)
    path.write_bytes(raw[:-30])
    session = load_session(path)
    assert len(session.readings) == 7 and "torn last record" in session.warnings[0]
    with SessionWriter.append_to(path) as writer:
        writer.write(ReadingRecord.from_json(reading(7)))
    assert values(path) == [5.0 + 0.001 * k for k in range(8)]


def test_a_changed_digit_is_named_and_salvage_keeps_the_rest(tmp_path):
    path = make_session(tmp_path / "s.jsonl")
    lines = path.read_text().splitlines(keepends=True)
    lines[3] = lines[3].replace('"reading_mm":5.002', '"reading_mm":5.092')
    path.write_text("".join(lines))
    with pytest.raises(SessionEdited, match=r"s.jsonl:4: fails its checksum: changed after it "
                                            "was written: the session was edited"):
        load_session(path)
    check = run_ogacq("session", "check", path)
    assert check.returncode == 2 and "s.jsonl:4: fails its checksum" in check.stdout
    assert "s.jsonl:5" not in check.stdout  # the chain break after it is the same edit
    saved = run_ogacq("session", "salvage", path, tmp_path / "saved.jsonl")
    assert saved.returncode == 0, saved.stderr
    assert "8 records written" in saved.stdout and "left out" in saved.stdout
    assert values(tmp_path / "saved.jsonl") == [5.0 + 0.001 * k for k in range(8) if k != 2]
    assert run_ogacq("session", "check", tmp_path / "saved.jsonl").returncode == 0
    (salvage,) = load_session(tmp_path / "saved.jsonl").of_type(SalvageRecord)
    assert salvage.left_out[0][0] == 4 and "checksum" in salvage.left_out[0][1]


def test_a_duplicated_line_is_dropped_once_with_a_warning(tmp_path):
    path = make_session(tmp_path / "s.jsonl")
    lines = path.read_text().splitlines(keepends=True)
    path.write_text("".join(lines[:5] + [lines[4]] + lines[5:]))
    session = load_session(path)
    assert len(session.readings) == 8
    assert any("dropped a copy of line 5" in w for w in session.warnings)


def test_renamed_keys_and_flipped_types_are_named_in_old_files_too(tmp_path):
    """Sessions written before the checksums: a record is still checked for the fields
    its type needs, and a reading turned into another type is not silently lost."""
    header = {"type": "session", "format": "ogacq-session/1", "machine": {}}
    good = {"type": "reading", **reading(0)}
    renamed = {k if k != "reading_mm" else "reading_m": v for k, v in good.items()}
    path = tmp_path / "old.jsonl"
    path.write_text("".join(json.dumps(r) + "\n" for r in (header, good, renamed, good)))
    with pytest.raises(InputError, match=r"old.jsonl:3: .*reading without a valid reading_mm"):
        load_session(path)


def test_fault_matrix_truncations_and_byte_flips(tmp_path):
    """Every cut within the last two records and 200 random byte flips: a one-line
    refusal naming the file and line, or the original readings (with a warning when
    a torn last record is dropped; a cut between two records leaves the file as it
    was before them): never a traceback, never a changed value."""
    original = make_session(tmp_path / "s.jsonl")
    raw = original.read_bytes()
    want = values(original)
    cases = []
    start = raw.rstrip(b"\n").rfind(b"\n", 0, raw.rstrip(b"\n").rfind(b"\n"))
    cases += [("cut", raw[:n]) for n in range(start, len(raw))]
    rng = np.random.default_rng(7)
    for _ in range(200):
        flipped = bytearray(raw)
        k = int(rng.integers(len(raw)))
        flipped[k] ^= 1 << int(rng.integers(7))
        cases.append(("flip", bytes(flipped)))
    counts = {"refused": 0, "intact": 0, "torn dropped": 0, "earlier state": 0}
    path = tmp_path / "case.jsonl"
    for _kind, data in cases:
        path.write_bytes(data)
        try:
            got = values(path)
        except (InputError, SessionEdited) as exc:
            assert str(exc).startswith(str(path)), exc
            counts["refused"] += 1
            continue
        if got == want:
            counts["intact"] += 1
        elif got == want[:len(got)] and not load_session(path).warnings:
            # cut between records (a newline may go with it): the file as it once was
            assert data.rstrip(b"\n").endswith(b'"}'), data[-40:]
            counts["earlier state"] += 1
        else:
            assert got == want[:len(got)] and load_session(path).warnings, (_kind, got)
            counts["torn dropped"] += 1
    print(f"\nfault matrix, {len(cases)} cases: {counts}")
    assert sum(counts.values()) == len(cases) and counts["refused"] > 100


def test_scan_counts_every_record(tmp_path):
    path = make_session(tmp_path / "s.jsonl", 3)
    scan = scan_session(path)
    assert len(scan.records) == 4 and not scan.problems
    kept, dropped = salvage_session(path, tmp_path / "copy.jsonl")
    assert kept == 4 and dropped == []


def test_a_session_that_cannot_be_written_is_refused_before_anything_moves(tmp_path):
    """A read-only place (here /sys, read-only even for root) or an existing session:
    ``ogacq run`` refuses with one line before the simulated machine is even started."""
    from tests.campaign.conftest import MACHINE

    (tmp_path / "machine.toml").write_text(MACHINE)
    for session, words in (("/sys/ogacq-test/s.jsonl", "cannot write the session here"),
                           (str(make_session(tmp_path / "old.jsonl")), "already exists")):
        campaign = tmp_path / "campaign.toml"
        campaign.write_text(f'machine = "machine.toml"\nsession = "{session}"\n'
                            "[simulator]\nseed = 1\n")
        proc = run_ogacq("run", campaign)
        assert proc.returncode == 2, proc.stdout + proc.stderr
        lines = proc.stderr.strip().splitlines()
        assert len(lines) == 1 and words in lines[0] and session in lines[0], proc.stderr
        assert "homing" not in proc.stdout and "[1/" not in proc.stdout
