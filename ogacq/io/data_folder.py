"""ogacq's own data folder: where what outlives one campaign is kept by default (the
history of the machines, the inventory of gauges the wizard met).

``$OGACQ_HOME`` when set, else the XDG data home's ``ogacq`` (XDG Base Directory
Specification 0.8: ``$XDG_DATA_HOME``, default ``~/.local/share``).
"""

from __future__ import annotations

import os
from pathlib import Path

ENVIRONMENT_VARIABLE = "OGACQ_HOME"


def data_folder() -> Path:
    given = os.environ.get(ENVIRONMENT_VARIABLE)
    if given and given.strip():
        return Path(given).expanduser()
    xdg = os.environ.get("XDG_DATA_HOME")
    # the specification: a relative path in $XDG_DATA_HOME is invalid and ignored
    base = Path(xdg) if xdg and Path(xdg).is_absolute() else Path.home() / ".local" / "share"
    return base / "ogacq"
