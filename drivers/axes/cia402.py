"""The CiA 402 device state machine as a master walks it to "operation enabled".

Sources: CiA 402-2 (= IEC 61800-7-201), the statusword's state coding (bits 0-3, 5
and 6) and the controlword's command coding (bits 0-3 and 7) with the transitions
of the power drive system's state machine; the same masks and values are in
python-canopen's ``State402.SW_MASK`` (canopen/profiles/p402.py) and Beckhoff's
EtherCAT SSC ``cia402appl.h``.

A master that enables a drive from the state the drive reports takes only the
transitions it needs. Sending "shutdown" (0x06) first, whatever the state, is
transition 8 from "operation enabled": the power stage switched off, so a
vertical axis with a brake drops onto it.
"""

from __future__ import annotations

from enum import Enum


class DriveState(Enum):
    """A state of the CiA 402 power drive system (statusword state coding)."""

    NOT_READY_TO_SWITCH_ON = "not ready to switch on"
    SWITCH_ON_DISABLED = "switch on disabled"
    READY_TO_SWITCH_ON = "ready to switch on"
    SWITCHED_ON = "switched on"
    OPERATION_ENABLED = "operation enabled"
    QUICK_STOP_ACTIVE = "quick stop active"
    FAULT_REACTION_ACTIVE = "fault reaction active"
    FAULT = "fault"


#: (mask, value, state): a statusword ``w`` is in ``state`` when ``w & mask == value``
#: [CiA 402-2 statusword state coding].
_STATE_CODING: tuple[tuple[int, int, DriveState], ...] = (
    (0x4F, 0x00, DriveState.NOT_READY_TO_SWITCH_ON),
    (0x4F, 0x40, DriveState.SWITCH_ON_DISABLED),
    (0x6F, 0x21, DriveState.READY_TO_SWITCH_ON),
    (0x6F, 0x23, DriveState.SWITCHED_ON),
    (0x6F, 0x27, DriveState.OPERATION_ENABLED),
    (0x6F, 0x07, DriveState.QUICK_STOP_ACTIVE),
    (0x4F, 0x0F, DriveState.FAULT_REACTION_ACTIVE),
    (0x4F, 0x08, DriveState.FAULT),
)

#: The controlword command that takes each state one step towards "operation
#: enabled", with its transition number [CiA 402-2 command coding]: shutdown
#: (0x06, 2), switch on (0x07, 3), enable operation (0x0F, 4; from "quick stop
#: active" 16, which a drive whose quick stop option code is 1-4 does not take: it
#: passes to "switch on disabled" itself once standing). Not ready to switch on,
#: fault reaction active and fault have none a master may send to enable.
TOWARDS_OPERATION: dict[DriveState, tuple[int, int]] = {
    DriveState.SWITCH_ON_DISABLED: (0x0006, 2),
    DriveState.READY_TO_SWITCH_ON: (0x0007, 3),
    DriveState.SWITCHED_ON: (0x000F, 4),
    DriveState.QUICK_STOP_ACTIVE: (0x000F, 16),
}

#: Statusword bit 10, target reached: after a quick stop, set once the drive stands
#: [CiA 402-2 statusword, bit 10].
TARGET_REACHED = 0x0400

#: Transitions from "switch on disabled", the farthest state, to "operation enabled".
MOST_TRANSITIONS = 3


def drive_state(statusword: int) -> DriveState | None:
    """The state a statusword codes, or None for a word that codes none (no CiA 402 drive)."""
    for mask, value, state in _STATE_CODING:
        if statusword & mask == value:
            return state
    return None
