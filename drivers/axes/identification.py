"""Who a drive says it is: Modbus Read Device Identification (function 43, MEI type
14; Modbus Application Protocol V1.1b3 §6.21), its basic objects 0x00 VendorName,
0x01 ProductCode and 0x02 MajorMinorRevision.

Recorded with every campaign for the traceability of the controller (which drive,
which firmware, the day of the readings), and how a campaign against ``ogacq sim``
is known as the rehearsal it is, whatever port or profile its campaign file names.
Most drives' manuals list no function 43 (IAI PCON, MR-JE-C, Kinco FD answer
exception 1): those are recorded as not answered, nothing more.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from ogacq_drivers.axes.controller import AxisController

# What the simulated controller answers as VendorName: ogacq's own, no source.
SIMULATOR_VENDOR = "ogacq simulator"
# §6.21's basic object ids, by the names the record gives them.
BASIC_OBJECTS = {"vendor": 0x00, "product": 0x01, "revision": 0x02}


def identify(controller: AxisController) -> dict[str, dict[str, str] | None]:
    """axis -> its drive's basic identification objects (vendor, product, revision),
    or None where the drive does not answer function 43/14; each device asked once."""
    asked: dict[tuple[int, int], dict[str, str] | None] = {}
    out: dict[str, dict[str, str] | None] = {}
    for axis in controller.axes:
        link, device = controller.link_of(axis), controller.device_ids[axis]
        key = (id(link), device)
        if key not in asked:
            objects = link.read_identification(device)
            asked[key] = None if objects is None else {
                name: objects.get(number, "") for name, number in BASIC_OBJECTS.items()}
        out[axis] = asked[key]
    return out


def simulated_by_identity(identification: Mapping[str, Any] | None) -> bool:
    """Whether every drive that answered said it is ogacq's simulator (and one did)."""
    answered = [v for v in (identification or {}).values() if isinstance(v, Mapping)]
    return bool(answered) and all(v.get("vendor") == SIMULATOR_VENDOR for v in answered)


def describe(identification: Mapping[str, Any] | None) -> str:
    """One line: each distinct drive's vendor, product and revision, or 'not answered'."""
    if not identification:
        return "not asked"
    seen: dict[str, list[str]] = {}
    for axis, said in identification.items():
        text = ("not answered (no function 43/14)" if not isinstance(said, Mapping) else
                " ".join(str(said.get(k) or "") for k in BASIC_OBJECTS).strip() or "blank")
        seen.setdefault(text, []).append(axis)
    return "; ".join(f"{', '.join(axes)}: {text}" for text, axes in seen.items())
