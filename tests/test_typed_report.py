"""The report reads documents through their types (issue 35, item 4: "0 `.get(` in
ogacq/report/"): the calibration record's inner sections are declared once
(``ogacq.record.declared``), so a view that reads a key by hand reads around the
declaration. A ``.get(`` on a module's constant table of words (``WORDS.get(key,
...)``, upper-case by the naming rule) is a lookup, not a document read, and allowed.

The record's sections, the diagnosis JSON and the session header's plan and station
are declared; two reads of what is not a document remain (``STILL_READ``). The
source is read as text, nothing imported.
"""

from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
REPORT = ROOT / "ogacq" / "report"

# a .get( on anything but an UPPER_CASE constant: the receiver as written before it
READ_BY_HAND = re.compile(r"(?<![\w.])((?:[\w)\]}]|\.)+)\.get\(")
CONSTANT = re.compile(r"[A-Z][A-Z0-9_]*")

# the reads by hand the report still makes: an error map's optional pitch (AxisMap's
# extra, of ogacq.model) and the environment's browser; neither a document it shows
STILL_READ = {"figures.py": 1, "printing.py": 1}


def reads_by_hand(text: str) -> list[str]:
    """The ``.get(`` calls of ``text`` on something other than a constant, numbered."""
    return [f"{number}: {line.strip()}" for number, line in enumerate(text.splitlines(), 1)
            for receiver in READ_BY_HAND.findall(line) if not CONSTANT.fullmatch(receiver)]


def test_the_pattern_finds_what_it_forbids():
    assert reads_by_hand('x = comp.get("outcome")\ny = (record.campaign or {}).get("a")\n'
                         'z = w.old_mm.get(a)\n') == [
        '1: x = comp.get("outcome")', '2: y = (record.campaign or {}).get("a")',
        '3: z = w.old_mm.get(a)']
    assert reads_by_hand('x = WORDS.get(key, key)\ny = comp.outcome\n') == []


def test_the_report_reads_its_documents_through_their_types():
    found = {}
    for path in sorted(REPORT.glob("*.py")):
        lines = reads_by_hand(path.read_text(encoding="utf-8"))
        if len(lines) > STILL_READ.get(path.name, 0):
            found[path.name] = lines
    assert not found, f"declare what these read (ogacq.record.declared): {found}"
