"""The words a write-back's audit trail and a calibration's end are told in, named once.

Each is a ``StrEnum``: a member is the word itself (it compares equal to it, and
``json`` and f-strings write it unchanged), so the session's audit records
(docs/formats.md), the procedure log, record.json and the history read exactly as
before the words were named; a misspelt member is an AttributeError where a misspelt
string was a branch never taken.
"""

from __future__ import annotations

from enum import StrEnum


class Stage(StrEnum):
    """A stage of a write-back's audit trail (an ``offsets`` or ``maps`` session
    record), and how the operation it belongs to ended."""

    REFUSED = "refused"  # the gate refused the plan: nothing written
    DECLINED = "declined"  # the operator said no: nothing written
    INTENT = "intent"  # fsynced before the first write, with what to restore
    DONE = "done"  # written and read back
    FAILED = "failed"  # the error, and what the controller held after it
    #: an operation's status only, never a record: an intent with no outcome (the
    #: process died, or was stopped, between the intent and its end)
    INTERRUPTED = "interrupted"


#: the stages that end an operation begun by its intent
ENDS = (Stage.DONE, Stage.FAILED)


class WriteOutcome(StrEnum):
    """How a calibration's write-back ended (``calibrate``'s outcome, its exit code,
    the record's and the history's words)."""

    VALIDATED = "validated"  # the validation campaign is within the gauge noise
    # within the noise, but its test would not see a map of its size go wrong along all
    # of its axis (ogacq.calibration.sight): kept, exit 0
    NOT_SHOWN = "not shown"
    IMPROVED = "improved"  # better than before, kept, but not within the noise
    RESTORED = "restored"  # the validation was worse: the previous state written back
    NOTHING_TO_CORRECT = "nothing to correct"  # the controller already holds it
    DECLINED = "declined"  # the operator declined the write
    REFUSED = "refused"  # the gate refused it
