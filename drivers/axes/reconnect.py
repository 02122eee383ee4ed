"""Riding out a dropped controller connection: reconnect within stated bounds, then
stop the axes and read their state again before anything else is commanded.

A Modbus TCP link drops when a switch restarts or a cable is re-seated; the drive
itself keeps running, and may have finished, or still be doing, the move it was
given. So a reconnect is not the end of it: the axes are stopped and their
positions and alarms re-read, and the caller decides from that state. When the
link stays down through every attempt, the fault is declared (LinkError).
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass
from typing import Any

from ogacq_drivers.axes.controller import AxisController
from ogacq_drivers.errors import DeviceTimeout, LinkError

log = logging.getLogger(__name__)

# One wait between attempts is never longer than this, however many attempts are allowed.
MAX_WAIT_S = 30.0


@dataclass(frozen=True)
class ReconnectPolicy:
    """``attempts`` reconnects, the first after ``backoff_s``, each next one after
    twice the previous wait (at most ``MAX_WAIT_S``); 0 attempts: a dropped link is
    a fault at once. The defaults ride out about half a minute of outage."""

    attempts: int = 5
    backoff_s: float = 1.0

    def waits_s(self) -> list[float]:
        return [min(self.backoff_s * 2.0 ** min(k, 32), MAX_WAIT_S)
                for k in range(self.attempts)]

    def as_dict(self) -> dict[str, Any]:
        return asdict(self)


@dataclass(frozen=True)
class Reconnected:
    """The axes as found after the connection came back (and they were stopped)."""

    attempts: int
    positions_mm: dict[str, float]
    alarms: dict[str, int]


def reconnect(controller: AxisController, policy: ReconnectPolicy, *,
              sleep: Callable[[float], None] = time.sleep) -> Reconnected:
    """Reconnect every link of ``controller`` until the drives answer a status read
    (bounded by ``policy``), then stop the axes and re-read positions and alarms.
    Raises LinkError when the drives stay unreachable; a drive that answers but
    refuses to stop raises its own DriverError."""
    last: Exception | None = None
    waited = 0.0
    for attempt, wait_s in enumerate(policy.waits_s(), 1):
        sleep(wait_s)
        waited += wait_s
        try:
            for link in controller.links:
                link.close()
                link.connect()
            controller.read_status()  # a connection is not an answer: ask the drives
        except (LinkError, DeviceTimeout) as exc:
            last = exc
            log.warning("controller: reconnect attempt %d/%d failed: %s", attempt,
                        policy.attempts, exc)
            continue
        controller.stop()
        statuses = controller.read_status()
        log.warning("controller: connection back after %d attempt(s); axes stopped at %s",
                    attempt, ", ".join(f"{a} {s.position_mm:.3f} mm"
                                       for a, s in statuses.items()))
        return Reconnected(attempt, {a: s.position_mm for a, s in statuses.items()},
                           {a: s.alarm_code for a, s in statuses.items()})
    raise LinkError(f"connection lost and not back after {policy.attempts} reconnect "
                    f"attempt(s) over {waited:g} s" + (f" (last: {last})" if last else ""))
