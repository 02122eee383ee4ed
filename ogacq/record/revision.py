"""Revisions of a record: the same campaign's record issued again with other content
(a validation added, a history grown, another ogacq) is a new issue that says so.

ISO/IEC 17025:2017 7.8.8: a report amended after issue is identified as such; a
completely new one is uniquely identified and refers to the original it replaces.
The record's id stays the campaign's (``OGQ-DATE-HASH``); each issue carries
``revision`` (1 for the first), and from 2 on ``revises`` (the revision, issue
time and SHA-256 of the issue it replaces, the ``record.json`` found beside it)
and ``changes`` (which parts differ from it). Issuing the same content again is
not a new revision: the earlier issue stands, its issue time too.
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Mapping
from typing import Any

from ogacq.record.calibration_record import CalibrationRecord

# What an issue adds to the content: not part of what is compared.
ISSUE_KEYS = ("issued", "revision", "revises", "changes")
# What differs from one evaluation to the next of the same content: how long it took.
TIMINGS = (("monte_carlo", "seconds"),)
MAX_CHANGES = 30  # listed one by one; more are counted


def content(record: Mapping[str, Any]) -> dict[str, Any]:
    """The record without what only its issue says, nor its evaluation's timings."""
    out = {k: v for k, v in record.items() if k not in ISSUE_KEYS}
    for section, key in TIMINGS:
        if isinstance(out.get(section), Mapping):
            out[section] = {k: v for k, v in out[section].items() if k != key}
    return out


def issue(record: Mapping[str, Any], previous: bytes | None) -> dict[str, Any]:
    """``record`` as issued beside ``previous`` (the bytes of the ``record.json`` it
    replaces, if any): revision 1 when there is none, or it is another record's or
    not a record; the earlier issue itself when the content is the same; else the
    next revision, naming the one it replaces and what changed."""
    earlier = _earlier_issue(previous, CalibrationRecord.from_json(record).id)
    if earlier is None:
        return {**record, "revision": 1}
    if json_equal(content(earlier), content(record)):
        return dict(earlier)
    assert previous is not None
    revision = _revision(earlier) + 1
    return {**record, "revision": revision,
            "revises": {"revision": revision - 1,
                        "issued": CalibrationRecord.from_json(earlier).as_written("issued"),
                        "sha256": hashlib.sha256(previous).hexdigest()},
            "changes": differences(content(earlier), content(record))}


def _earlier_issue(previous: bytes | None, record_id: Any) -> dict[str, Any] | None:
    if previous is None:
        return None
    try:
        earlier = json.loads(previous.decode("utf-8"))
    except (UnicodeDecodeError, ValueError):
        return None  # not a record: nothing to revise (the file is replaced whole)
    if not isinstance(earlier, dict) or CalibrationRecord.from_json(earlier).as_written("id") \
            != record_id:
        return None
    return earlier


def _revision(record: Mapping[str, Any]) -> int:
    revision = CalibrationRecord.from_json(record).revision
    return revision if revision is not None and revision >= 1 else 1  # before revisions


def json_equal(a: Any, b: Any) -> bool:
    """Equal as JSON would write them (a tuple is a list)."""
    return json.dumps(a, sort_keys=True, allow_nan=False) == \
        json.dumps(b, sort_keys=True, allow_nan=False)


def differences(old: Mapping[str, Any], new: Mapping[str, Any], prefix: str = "",
                depth: int = 2) -> list[str]:
    """What differs, by key, two levels down: ``added validation_session``,
    ``changed acceptance.as_left``, ``changed history (1 -> 2 entries)``."""
    out: list[str] = []
    for key in dict.fromkeys([*old, *new]):
        name = f"{prefix}{key}"
        if key not in old or (old[key] is None and new.get(key) is not None):
            out.append(f"added {name}")
        elif key not in new or (new[key] is None and old[key] is not None):
            out.append(f"removed {name}")
        elif json_equal(old[key], new[key]):
            continue
        elif isinstance(old[key], Mapping) and isinstance(new[key], Mapping) and depth > 1:
            out += differences(old[key], new[key], f"{name}.", depth - 1) or [f"changed {name}"]
        elif isinstance(old[key], list) and isinstance(new[key], list) \
                and len(old[key]) != len(new[key]):
            out.append(f"changed {name} ({len(old[key])} -> {len(new[key])} entries)")
        else:
            out.append(f"changed {name}")
    if not prefix and len(out) > MAX_CHANGES:
        out = out[:MAX_CHANGES] + [f"and {len(out) - MAX_CHANGES} more"]
    return out
