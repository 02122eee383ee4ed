"""A session read again in the same process: only the lines not read before are decoded
(a campaign reads its session after each stage appends to it), and what is read is the
file as it is now: a record appended is there, a line changed since is found."""

from __future__ import annotations

import pytest

from ogacq.io.errors import InputError
from ogacq.session import seal
from ogacq.session.records import EndRecord, ReadingRecord
from ogacq.session.store import SessionEdited, SessionWriter, load_session


def reading(k: int) -> ReadingRecord:
    return ReadingRecord.from_json({
        "step": f"x/c1/p{k}", "gauge": "y_x", "leg": "x", "gauge_axis": "y", "cycle": 1,
        "t_s": 1.5 * k, "q_mm": [0.1 * k, 0.0, 0.0], "tcp_mm": [0.0, 0.0, 0.0],
        "approach": [1, 0, 0], "reading_mm": 5.0 + 0.001 * k})


@pytest.fixture
def session(tmp_path):
    path = tmp_path / "s.jsonl"
    with SessionWriter.create(path, {"machine": {"leg_length_mm": 310.25}, "plan": None}) as w:
        for k in range(6):
            w.write(reading(k))
    return path


@pytest.fixture
def decoded(monkeypatch) -> list[bytes]:
    """Every line decoded from here on."""
    lines: list[bytes] = []
    decode = seal._decode

    def counted(line: bytes) -> seal.Decoded:
        lines.append(line)
        return decode(line)
    monkeypatch.setattr(seal, "_decode", counted)
    return lines


def fresh(path) -> list:
    seal._DECODED.clear()  # as a new process reads it
    return load_session(path).records


def test_a_record_appended_since_is_read_and_only_the_new_lines_decoded(session, decoded):
    first = load_session(session)
    assert len(decoded) == 8  # the header, six readings, the closed record
    assert load_session(session).records == first.records and len(decoded) == 8
    with SessionWriter.append_to(session, first.size_bytes) as writer:
        writer.write(EndRecord(status="complete"))
    again = load_session(session)
    assert len(decoded) == 8 + 2  # the end and its writer's closed record
    assert again.finished and again.records == fresh(session)
    assert again.size_bytes > first.size_bytes


def test_a_line_changed_since_the_last_reading_is_found(session):
    load_session(session)
    lines = session.read_bytes().split(b"\n")
    lines[3] = lines[3].replace(b'"reading_mm":5.002', b'"reading_mm":5.092')
    session.write_bytes(b"\n".join(lines))  # same size, same line count
    with pytest.raises(SessionEdited, match=r"s\.jsonl:4: fails its checksum"):
        load_session(session)


def test_a_line_read_as_wrong_before_is_refused_again(session):
    text = session.read_bytes().replace(b'"cycle":1', b'"cycle":"1"', 1)
    session.write_bytes(text)
    for _ in range(2):
        with pytest.raises(InputError, match=r"s\.jsonl:2: corrupt record: reading without a "
                           "valid cycle: must be a whole number"):
            load_session(session)


def test_only_the_files_read_last_are_kept(tmp_path, session):
    for k in range(seal.DECODED_FILES + 2):
        other = tmp_path / f"o{k}.jsonl"
        other.write_bytes(session.read_bytes())
        load_session(other)
    assert len(seal._DECODED) == seal.DECODED_FILES
    assert (tmp_path / f"o{seal.DECODED_FILES + 1}.jsonl").resolve() in seal._DECODED
