"""The project's exceptions, for ``ogacq`` code to import from one place.

The root and its branches live in ``drivers.errors`` (``drivers`` never imports
``ogacq``); the command line maps the branches to exit codes (README, "Exit
codes"). Errors of one stage derive from a branch next to the code that raises
them: ``DiagnosisError`` is an ``InputError``, ``WriteBackError`` a
``DriverError``, ``CampaignStopped`` a stop of its own (exit 3, 130 when the
operator interrupted).
"""

from __future__ import annotations

from drivers.errors import DriverError, InputError, OgacqError, Refused

__all__ = ["DriverError", "InputError", "OgacqError", "Refused"]
