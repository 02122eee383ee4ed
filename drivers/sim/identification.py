"""The simulated controller's answer to Read Device Identification (function 43, MEI
type 14; Modbus Application Protocol V1.1b3 §6.21): VendorName "ogacq simulator",
ProductCode the profile it serves, MajorMinorRevision the simulated drive's.

pymodbus answers 43/14 from one process-wide control block, so a server given an
identity would lend it to every other pymodbus server in the process (a test's
"real" drive among them). The simulator puts its own objects into the answer as it
leaves (the server's ``trace_pdu`` hook) instead.
"""

from __future__ import annotations

from collections.abc import Callable

from pymodbus.pdu import ModbusPDU
from pymodbus.pdu.mei_message import ReadDeviceInformationResponse

from ogacq_drivers.axes.identification import BASIC_OBJECTS, SIMULATOR_VENDOR

REVISION = "1.0"  # the simulated drive's own revision: no source (ours)
# §6.21 conformity level 0x81: basic identification, stream and individual access
BASIC_CONFORMITY = 0x81


def answer_identification(profile: str) -> Callable[[bool, ModbusPDU], ModbusPDU]:
    """A ``trace_pdu`` hook that answers every Read Device Identification with the
    basic objects of a simulated drive serving ``profile`` (the only objects it has)."""
    objects = {BASIC_OBJECTS["vendor"]: SIMULATOR_VENDOR.encode("ascii"),
               BASIC_OBJECTS["product"]: profile.encode("ascii", "replace"),
               BASIC_OBJECTS["revision"]: REVISION.encode("ascii")}

    def hook(sending: bool, pdu: ModbusPDU) -> ModbusPDU:
        if sending and isinstance(pdu, ReadDeviceInformationResponse):
            pdu.information = dict(objects)
            pdu.conformity = BASIC_CONFORMITY
        return pdu

    return hook
