"""The controller a session's write-back goes to: the campaign file naming it (the one
the session was run with, or the one given), its profile, and what the profile alone
rules out, said before anything is connected; then the controller opened with the
session's audit log held first, so a campaign running on the session (or another
write-back) refuses this one before anything moves.

``ogacq offsets show|write|restore`` and a return to a state of the history come here.
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterator
from pathlib import Path

from ogacq_drivers.axes.controller import AxisController
from ogacq_drivers.axes.profile import Profile, ProfileError, load_profile
from ogacq.campaign.campaign_file import Campaign, ControllerSpec, read_campaign
from ogacq.campaign.station import open_controller
from ogacq.errors import InputError
from ogacq.session.store import LoadedSession
from ogacq.writeback.audit import AuditLog


def session_controller(session: LoadedSession, path: Path | None,
                       ) -> tuple[Campaign, ControllerSpec, Profile]:
    """The campaign file naming the controller, the controller and its profile; a
    campaign that only starts the built-in simulator names no controller that outlives
    the command."""
    if path is None:
        recorded = session.header.campaign_file
        if not recorded:
            raise InputError(session.path, "the session names no campaign file; give the "
                             "controller's with --campaign")
        path = Path(recorded)
    campaign = read_campaign(path)
    if campaign.simulator is not None or campaign.controller is None:
        raise InputError(campaign.path, "this campaign starts the built-in simulator inside "
                         "each command, and its controller does not outlive it; serve one with "
                         "`ogacq sim` and name it in [controller]")
    spec = campaign.controller
    try:
        profile = load_profile(spec.profile)
    except ProfileError as exc:
        raise InputError(campaign.path, f"controller profile: {exc}") from None
    return campaign, spec, profile


def check_writable(campaign: Campaign, spec: ControllerSpec, profile: Profile,
                   save_nvm: bool) -> None:
    """What the profile alone rules out, said before connecting to anything."""
    if profile.offset.kind == "software" and spec.offsets_file is None:
        raise InputError(campaign.path, f"profile {spec.profile!r} has no offset register; "
                         "its offsets live in a software offset table: add offsets_file = "
                         "\"offsets.toml\" to [controller] so that every campaign applies it")
    if save_nvm and profile.nvm.kind == "none":
        raise InputError("--save-nvm", f"profile {spec.profile!r} has no non-volatile memory; "
                         "its offsets persist in the software offset table")


@contextlib.contextmanager
def controller_of(session: LoadedSession, campaign_path: Path | None, save_nvm: bool,
                  ) -> Iterator[tuple[ControllerSpec, AuditLog, AxisController]]:
    """The session's campaign's controller, its audit log and the controller opened, in
    that order:
    the session is held before the controller is touched, so a campaign running on it
    (or another write-back) refuses this one before anything moves."""
    campaign, spec, profile = session_controller(session, campaign_path)
    check_writable(campaign, spec, profile, save_nvm)
    with AuditLog(session) as audit, open_controller(spec) as controller:
        yield spec, audit, controller
