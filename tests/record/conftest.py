from __future__ import annotations

from pathlib import Path

import pytest

from tests.record.sessions import as_before, run_campaign, with_context


@pytest.fixture(scope="session")
def campaign_sessions(tmp_path_factory) -> tuple[Path, Path]:
    """One simulated campaign, as recorded (a session from before the record's
    context was recorded) and as a session that records its context."""
    root = tmp_path_factory.mktemp("record")
    ran = run_campaign(root / "campaign")
    return (as_before(ran, root / "before" / "session.jsonl"),
            with_context(ran, root / "with-context" / "session.jsonl"))
