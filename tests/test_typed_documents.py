"""The session header and the calibration record are read through their types
(``ogacq.session.header.SessionHeader``, ``ogacq.record.calibration_record``
``CalibrationRecord`` and its sections in ``ogacq.record.sections``): no other module
of ogacq reads either document by hand as a dict (issue 28, "What it must show").

The source is read as text, nothing imported.
"""

from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "ogacq"

# the modules that read the JSON objects into the types
READERS = frozenset({
    "ogacq/session/json_document.py", "ogacq/session/header.py",
    "ogacq/record/calibration_record.py", "ogacq/record/sections.py"})
# a dict read by hand: record.get("..."), header.get(...), typed.header.get(...)
BY_HAND = re.compile(r"\b(?:record|header)\.get\(")


def by_hand(text: str) -> list[str]:
    """The lines of ``text`` that read a record or a header as a dict, numbered."""
    return [f"{number}: {line.strip()}" for number, line in enumerate(text.splitlines(), 1)
            if BY_HAND.search(line)]


def test_the_pattern_finds_what_it_forbids():
    assert by_hand('x = record.get("verdict")\ny = session.header.get("plan")\n') == [
        '1: x = record.get("verdict")', '2: y = session.header.get("plan")']
    assert by_hand('x = typed.verdict\ny = line.get("type")\nz = recorded.get(1)\n') == []


def test_no_module_reads_the_record_or_the_header_by_hand():
    found = {}
    for path in sorted(PACKAGE.rglob("*.py")):
        name = path.relative_to(ROOT).as_posix()
        if name not in READERS and (lines := by_hand(path.read_text(encoding="utf-8"))):
            found[name] = lines
    assert not found, ("read these through CalibrationRecord / SessionHeader and their "
                       f"typed sections: {found}")


def test_the_readers_are_there():
    assert all((ROOT / name).is_file() for name in READERS)
