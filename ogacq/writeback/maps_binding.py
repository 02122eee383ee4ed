"""The maps file against the history's last maps state of its machine.

The maps file moves every target a campaign commands, and a file is easy to lose or
swap: deleted, a link left dangling, emptied, or another calibration's copied in.
Each of those ran silently (uncompensated, or with maps no one validated on this
machine). The history knows which maps the machine's last maps write or restore left;
a file holding anything else is refused, with both checksums, before anything moves.
A write that did not finish (its audit has no ``done``) may have left either its old
or its new maps: both are accepted, as ``calibrate --resume`` decides from the file.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import TYPE_CHECKING

from ogacq.errors import InputError, OgacqError
from ogacq.logs import logger
from ogacq.writeback.maps_table import MapsTable, maps_checksum, read_maps_table
from ogacq.writeback.outcome import Stage

if TYPE_CHECKING:  # the history is imported when one is given, not at start-up
    from ogacq.campaign.campaign_file import Campaign
    from ogacq.history.location import HistoryLocation
    from ogacq.history.store import MapState

log = logger(__name__)


def check_maps_in_force(table: MapsTable, name: str, serial: str,
                        location: HistoryLocation | None) -> None:
    """Refuse a maps file that is not what the history says the machine holds (no
    history, or no maps state of the machine for this file in it: nothing to compare)."""
    if location is None:
        return
    states = [v for v in _maps_states(location, name, serial)
              if v.maps_file and _same_file(v.maps_file, table.path)]
    if not states:
        return
    done = [k for k, v in enumerate(states) if v.stage == "after" and v.status == Stage.DONE]
    if not done:
        return
    last = states[done[-1]]
    # what the last finished operation left, or either side of any that followed
    accepted = {v.checksum or maps_checksum({}) for v in states[done[-1]:]}
    if table.checksum in accepted:
        return
    held = "no file" if not table.exists else \
        "no maps" if not table.maps else f"maps {table.checksum[:12]}"
    raise InputError(table.path, f"holds {held} (checksum {table.checksum[:12]}), but the "
                     f"history's last maps state of this machine, {last.state_id} "
                     f"({last.action} {last.operation}), left "
                     f"{(last.checksum or maps_checksum({}))[:12]}: the maps file was "
                     "deleted, emptied or replaced (another calibration's copied in?); put "
                     "back the file that state names, or go back to a state with `ogacq "
                     "maps restore`")


def check_campaign_maps(campaign: Campaign, option: str | None) -> None:
    """``check_maps_in_force`` for a campaign about to run with a maps file, against the
    history it will be recorded into (``--history``, the environment or the default)."""
    spec = campaign.controller
    if spec is None or spec.maps_file is None:
        return
    from ogacq.history.location import history_for_session

    try:
        location = history_for_session(option, campaign.session)
    except OgacqError:  # said again, and not fatal, when the campaign is recorded
        return
    machine = campaign.machine
    check_maps_in_force(read_maps_table(spec.maps_file, owner=(machine.name, machine.serial)),
                        machine.name, machine.serial, location)


def _same_file(recorded: str, path: Path) -> bool:
    return os.path.realpath(recorded) == os.path.realpath(path)


def _maps_states(location: HistoryLocation, name: str, serial: str) -> list[MapState]:
    from ogacq.history.store import History

    if location.path is not None and not location.path.exists():
        return []  # no history yet: nothing recorded to compare with
    try:
        with History.open(location, create=False) as db:
            machines = [m for m in db.machines()
                        if (serial and m.serial == serial) or (not serial and m.name == name)]
            return db.map_states(machines[0]) if len(machines) == 1 else []
    except (OgacqError, OSError, ImportError) as exc:  # none yet, unreachable: said, not fatal
        log.warning("the maps file is not compared with the history: %s", exc)
        return []
