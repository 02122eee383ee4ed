"""The session header as a type (ogacq.session.header): every session's first line
read and written back exactly, old and unknown keys included."""

from __future__ import annotations

import json
from pathlib import Path

from ogacq.session.header import SessionHeader
from ogacq.session.store import load_session

GOLDEN = Path(__file__).resolve().parents[1] / "golden"


def first_line(path: Path) -> dict:
    return json.loads(path.read_text(encoding="utf-8").splitlines()[0])


def test_a_campaign_s_header_reads_as_it_was_written():
    for name in ("session.jsonl", "session-context.jsonl"):
        # the seal (seq, crc) is checked and dropped on loading (ogacq.session.seal)
        line = {k: v for k, v in first_line(GOLDEN / name).items() if k not in ("seq", "crc")}
        header = load_session(GOLDEN / name).header
        assert json.dumps(header.to_json()) == json.dumps(line)  # keys, order, values
        assert header.station is not None and header.plan is not None
        assert header.plan["legs"] == ["x", "y", "z"]
        assert header.simulated is True and header.software == line["software"]
        assert set(header.gauges) == {"y_x", "z_x", "x_y", "z_y", "x_z", "y_z"}
        # the line's type is the store's to check: kept as written
        assert set(header.extra) == {"type"}


def test_unknown_keys_and_unexpected_types_are_kept_where_they_were():
    line = {"type": "session", "format": "ogacq-session/1", "from_the_future": {"a": [1]},
            "machine": "not a table", "plan": None, "instruments": [{"gauge": "y_x"}, 3],
            "simulated": "yes", "created": "2026-01-10T09:00:00+0000"}
    header = SessionHeader.from_json(line)
    assert json.dumps(header.to_json()) == json.dumps(line)
    assert header.machine is None and header.simulated is None  # not what this version writes
    assert header.extra["machine"] == "not a table"
    assert header.extra["from_the_future"] == {"a": [1]}
    assert header.plan is None and "plan" in header  # present, and null
    assert "station" not in header and header.gauges == {}
    assert header.instruments == [{"gauge": "y_x"}, 3]


def test_a_header_built_in_code_writes_its_named_keys_then_the_others():
    header = SessionHeader(software="ogacq 0.1.0", plan={"legs": ["x"]}, extra={"note": "n"})
    assert header.to_json() == {"software": "ogacq 0.1.0", "plan": {"legs": ["x"]}, "note": "n"}
    assert list(header.to_json()) == ["software", "plan", "note"]
    assert SessionHeader.from_json(header.to_json()) == SessionHeader.from_json(
        {"software": "ogacq 0.1.0", "plan": {"legs": ["x"]}, "note": "n"})
