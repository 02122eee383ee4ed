"""Issue 26: a session's integrity cannot be switched off. Every record of a sealed
session carries its sequence number, the checksum of the line before it and its own;
an edit is found whichever of them it deleted, and an analysis refuses it unless the
user accepts the session as it stands. Older sessions are told by their header, and
say so. The checks here are written against the format (docs/formats.md, "Sessions"),
recomputing CRC-32 with zlib, not with the store's own functions."""

from __future__ import annotations

import json
import zlib

import pytest

from ogacq.io.errors import InputError
from ogacq.session import seal
from ogacq.session.records import EndRecord, ReadingRecord
from ogacq.session.seal import SEAL, UNCHECKED
from ogacq.session.store import SessionEdited, SessionWriter, load_session, scan_session


def reading(k: int) -> ReadingRecord:
    return ReadingRecord.from_json({
        "step": f"x/c1/p{k}", "gauge": "y_x", "leg": "x", "gauge_axis": "y", "cycle": 1,
        "t_s": 1.5 * k, "q_mm": [0.1 * k, 0.0, 0.0], "tcp_mm": [0.0, 0.0, 0.0],
        "approach": [1, 0, 0], "reading_mm": 5.0 + 0.001 * k})


@pytest.fixture
def sealed(tmp_path):
    path = tmp_path / "s.jsonl"
    with SessionWriter.create(path, {"machine": {"leg_length_mm": 310.25}, "plan": None}) as w:
        for k in range(6):
            w.write(reading(k))
        w.write(EndRecord(status="complete"))
    return path


def lines_of(path) -> list[dict]:
    return [json.loads(line) for line in path.read_text().splitlines()]


def write_lines(path, records: list[dict]) -> None:
    path.write_text("".join(json.dumps(r, separators=(",", ":")) + "\n" for r in records))


def crc_of(record: dict) -> str:
    """The format's checksum: CRC-32 of the compact JSON line without its crc key."""
    body = json.dumps({k: v for k, v in record.items() if k != "crc"}, separators=(",", ":"))
    return f"{zlib.crc32(body.encode()):08x}"


def test_every_line_carries_its_seal_and_the_header_says_so(sealed):
    raw = sealed.read_bytes().splitlines()
    records = lines_of(sealed)
    assert records[0]["integrity"] == SEAL and "prev" not in records[0]
    for k, record in enumerate(records):
        assert record["seq"] == k and record["crc"] == crc_of(record)
        assert list(record)[-1] == "crc"
        if k:  # the chain: the CRC-32 of the line before, as written
            assert record["prev"] == f"{zlib.crc32(raw[k - 1]):08x}"
    session = load_session(sealed)
    assert session.integrity.mode == "sealed" and session.integrity.notes() == []


@pytest.mark.parametrize("deleted", [("crc",), ("crc", "seq"), ("crc", "prev"),
                                     ("crc", "seq", "prev")])
def test_a_reading_changed_with_its_seal_deleted_is_refused_every_time(sealed, deleted):
    """The red team's 20/20: a reading moved by 0.05 mm with its crc removed (and seq,
    prev) passed `session check` and changed the fit; now each is refused, and with
    --accept-edited the value is used and the session says which line was edited."""
    records = lines_of(sealed)
    for line in range(2, 8):  # every reading
        edited = [dict(r) for r in records]
        edited[line - 1]["reading_mm"] += 0.05
        for key in deleted:
            edited[line - 1].pop(key)
        write_lines(sealed, edited)
        with pytest.raises(SessionEdited, match=rf"s\.jsonl:{line}: ") as caught:
            load_session(sealed)
        assert "--accept-edited" in str(caught.value) and "salvage" in str(caught.value)
        accepted = load_session(sealed, accept_edited=True)
        assert accepted.readings[line - 2].reading_mm == pytest.approx(
            records[line - 1]["reading_mm"] + 0.05)
        assert accepted.integrity.edited[0][0] == line
        assert accepted.integrity.notes()[0].startswith(f"edited: line {line} ")


def test_a_header_edited_without_its_checksum_is_refused(sealed):
    records = lines_of(sealed)
    records[0]["machine"]["leg_length_mm"] = 300.0
    del records[0]["crc"]
    write_lines(sealed, records)
    with pytest.raises(SessionEdited, match=r"s\.jsonl:1: has no checksum"):
        load_session(sealed)


def test_a_bit_flip_in_a_key_name_is_an_edit_not_an_old_session(sealed):
    text = sealed.read_text().splitlines()
    text[3] = text[3].replace('"crc":', '"czc":')
    sealed.write_text("\n".join(text) + "\n")
    with pytest.raises(SessionEdited, match=r"s\.jsonl:4: "):
        load_session(sealed)


def test_a_record_removed_is_found_even_when_the_rest_is_renumbered(sealed):
    records = lines_of(sealed)
    write_lines(sealed, records[:3] + records[4:])
    with pytest.raises(SessionEdited, match=r"s\.jsonl:4: out of sequence"):
        load_session(sealed)
    # a forger renumbers and recomputes every crc: the chain still breaks at the gap
    forged = records[:3] + records[4:]
    for seq, record in enumerate(forged):
        record["seq"] = seq
        record["crc"] = crc_of(record)
    write_lines(sealed, forged)
    with pytest.raises(SessionEdited, match=r"s\.jsonl:4: does not follow line 3 as written"):
        load_session(sealed)


def test_a_line_written_twice_is_dropped_and_the_chain_goes_on(sealed):
    text = sealed.read_text().splitlines(keepends=True)
    sealed.write_text("".join(text[:4] + [text[3]] + text[4:]))
    session = load_session(sealed)
    assert len(session.readings) == 6 and "dropped a copy of line 4" in session.warnings[0]


def test_checksums_without_the_chain_are_no_format_of_their_own(tmp_path):
    """Per-record checksums without a seal in the header (0.1.0's development only):
    read as unchecked, a record changed after it was written still refused."""
    header = {"type": "session", "format": "ogacq-session/1", "machine": {}, "plan": None}
    records = [header, *({"type": "reading", "wall": 1.0, **reading(k).to_json()}
                         for k in range(3))]
    for seq, record in enumerate(records):
        record["seq"] = seq
        record["crc"] = crc_of(record)
    path = tmp_path / "older.jsonl"
    write_lines(path, records)
    session = load_session(path)
    assert session.integrity.mode == UNCHECKED
    assert session.integrity.notes()[0].startswith("unchecked: ")
    records[2]["reading_mm"] += 0.05
    write_lines(path, records)
    with pytest.raises(SessionEdited, match=r"older\.jsonl:3: fails its checksum"):
        load_session(path)


def test_a_session_from_before_the_checksums_loads_and_says_so(tmp_path):
    header = {"type": "session", "format": "ogacq-session/1", "machine": {}}
    path = tmp_path / "old.jsonl"
    write_lines(path, [header, {"type": "reading", **reading(0).to_json()}])
    session = load_session(path)
    assert session.integrity.mode == UNCHECKED and len(session.readings) == 1
    assert session.integrity.notes()[0].startswith("unchecked: ")


def test_a_sealed_session_whose_header_lost_its_seal_is_refused(sealed):
    """Stripping the header's integrity and crc does not make a sealed session an old
    one: its records still carry their chain."""
    records = lines_of(sealed)
    del records[0]["integrity"], records[0]["crc"], records[0]["seq"]
    records[2]["reading_mm"] += 0.05
    del records[2]["crc"]
    write_lines(sealed, records)
    scan = scan_session(sealed)
    assert scan.mode == UNCHECKED
    assert [line for line, _ in scan.edited][:1] == [2]  # the first line with a chain
    with pytest.raises(SessionEdited):
        load_session(sealed)


def test_salvage_keeps_records_as_written_and_seals_the_new_file(sealed, tmp_path):
    from ogacq.session.store import salvage_session

    records = lines_of(sealed)
    records[3]["reading_mm"] += 0.05  # changed: its crc fails
    write_lines(sealed, records[:5] + records[6:])  # and line 6 removed: line 7 out of chain
    kept, left_out = salvage_session(sealed, tmp_path / "saved.jsonl")
    assert [line for line, _ in left_out] == [4]
    saved = load_session(tmp_path / "saved.jsonl")
    assert kept == 6 and saved.integrity.mode == "sealed" and not saved.integrity.edited
    assert [r.reading_mm for r in saved.readings] == [
        r["reading_mm"] for r in records[1:7] if r["seq"] not in (3, 5)]
    assert saved.finished  # the end record was as written


# A session read again in the same process: only the lines not read before are decoded
# (a campaign reads its session after each stage appends to it), and what is read is the
# file as it is now: a record appended is there, a line changed since is found.

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


def test_a_record_appended_since_is_read_and_only_the_new_lines_decoded(sealed, decoded):
    first = load_session(sealed)
    assert len(decoded) == 9  # the header, six readings, the end, the closed record
    assert load_session(sealed).records == first.records and len(decoded) == 9
    with SessionWriter.append_to(sealed, first.size_bytes) as writer:
        writer.write(reading(6))
    again = load_session(sealed)
    assert len(decoded) == 9 + 2  # the reading and its writer's closed record
    assert again.readings[-1].step == "x/c1/p6" and again.size_bytes > first.size_bytes
    seal._DECODED.clear()  # as a new process reads it
    assert again.records == load_session(sealed).records


def test_a_line_changed_since_the_last_reading_is_found(sealed):
    load_session(sealed)
    lines = sealed.read_bytes().split(b"\n")
    lines[3] = lines[3].replace(b'"reading_mm":5.002', b'"reading_mm":5.092')
    sealed.write_bytes(b"\n".join(lines))  # same size, same line count
    with pytest.raises(SessionEdited, match=r"s\.jsonl:4: fails its checksum"):
        load_session(sealed)


def test_a_line_read_as_wrong_before_is_refused_again(sealed):
    sealed.write_bytes(sealed.read_bytes().replace(b'"cycle":1', b'"cycle":"1"', 1))
    for _ in range(2):
        with pytest.raises(InputError, match=r"s\.jsonl:2: corrupt record: reading without a "
                           "valid cycle: must be a whole number"):
            load_session(sealed)


def test_only_the_files_read_last_are_kept(tmp_path, sealed):
    for k in range(seal.DECODED_FILES + 2):
        other = tmp_path / f"o{k}.jsonl"
        other.write_bytes(sealed.read_bytes())
        load_session(other)
    assert len(seal._DECODED) == seal.DECODED_FILES
    assert (tmp_path / f"o{seal.DECODED_FILES + 1}.jsonl").resolve() in seal._DECODED
