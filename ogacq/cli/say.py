"""The one line on stderr that every error of ``ogacq`` comes down to."""

from __future__ import annotations

import sys

from ogacq.cli.plain import plain


def say(kind: str, message: str) -> None:
    """One line on stderr, whatever line breaks or control characters the message had
    (it may quote a recorded name, a file's line or a device's reply)."""
    text = " ".join(part.strip() for part in message.splitlines() if part.strip())
    print(f"ogacq: {kind}: {plain(text)}", file=sys.stderr, flush=True)
