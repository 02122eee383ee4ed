"""The report reads documents through their types (issue 35, item 4: "0 `.get(` in
ogacq/report/"): the calibration record's sections, the diagnosis JSON, the session
header's plan, station and machine, and an error map's extra are declared once
(``ogacq.record.declared``), so a view that reads a key by hand reads around the
declaration. A constant table of words says once what a key not in it reads as
(``ogacq.report.cells.Fallback``), so no lookup needs ``.get(`` either; nor do the
page's templates, which are given typed values.

The source is read as text, nothing imported.
"""

from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
REPORT = ROOT / "ogacq" / "report"

READ_BY_HAND = re.compile(r"\.get\(")


def reads_by_hand(text: str) -> list[str]:
    """The lines of ``text`` with a ``.get(`` call, numbered."""
    return [f"{number}: {line.strip()}" for number, line in enumerate(text.splitlines(), 1)
            if READ_BY_HAND.search(line)]


def test_the_pattern_finds_what_it_forbids():
    assert reads_by_hand('x = comp.get("outcome")\ny = WORDS.get(key, key)\n'
                         '{{ rec.missing.get("history") }}\n') == [
        '1: x = comp.get("outcome")', '2: y = WORDS.get(key, key)',
        '3: {{ rec.missing.get("history") }}']
    assert reads_by_hand('x = WORDS[key]\ny = comp.outcome\nz = os.getenv("X")\n') == []


def test_the_report_and_its_templates_read_their_documents_through_their_types():
    found = {path.relative_to(REPORT).as_posix(): lines for path in sorted(REPORT.rglob("*"))
             if path.suffix in (".py", ".j2")
             and (lines := reads_by_hand(path.read_text(encoding="utf-8")))}
    assert not found, f"declare what these read (ogacq.record.sections): {found}"
