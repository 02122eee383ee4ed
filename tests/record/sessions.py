"""Sessions for the record's tests: a real simulated campaign (drivers, gauges on
pseudo-terminals, Modbus controller), and the same campaign as a session that
records its context (docs/calibration-record.md section 2: identity, instruments
with certificates, temperatures, an expired gauge run under an override)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path
from typing import Any

from ogacq.session.records import EnvironmentRecord, OverrideRecord
from ogacq.session.store import SessionWriter, load_session
from tests.campaign.conftest import write_campaign

DATE = "2026-01-10T09:00:00"
OPERATOR = "J. Martin"
MACHINE_NAME = "OG-1 cell 3"
MACHINE_SERIAL = "OG-2026-0017"
OVERRIDE_REASON = "re-checked against gauge blocks on 2026-01-09"
# y_x's certificate ran out before the campaign's date: it ran under the override
INSTRUMENTS: list[dict[str, Any]] = [
    {"gauge": key, "make": "Mitutoyo", "model": "543-790B", "serial": f"1234{k:04d}",
     "certificate": f"DKD-K-12345 2025-{k:04d}", "calibrated": "2025-01-05" if k else "2024-12-01",
     "due": "2026-01-01" if key == "y_x" else "2027-01-05", "uncertainty_mm": 0.0015,
     "uncertainty_k": 2.0, "resolution_mm": 0.001}
    for k, key in enumerate(("y_x", "z_x", "x_y", "z_y", "x_z", "y_z"))]
HISTORY = [
    {"id": "OGQ-20250110-0a1b2c3d", "date": "2025-01-10T09:12:00",
     "results": {"joint_offset": {"x": {"value_mm": -1.2391, "U_mm": 0.0041},
                                  "y": {"value_mm": -0.7934, "U_mm": 0.0041},
                                  "z": {"value_mm": 0.9011, "U_mm": 0.0042}}}},
    {"id": "OGQ-20250712-4e5f6a7b", "date": "2025-07-12T14:30:00",
     "results": {"joint_offset": {"x": {"value_mm": -1.2417, "U_mm": None},
                                  "y": {"value_mm": -0.7902, "U_mm": None},
                                  "z": {"value_mm": 0.9050, "U_mm": None}}}},
]


def run_campaign(folder: Path, seed: int = 3) -> Path:
    """``ogacq run`` of a simulated campaign; its session."""
    path = write_campaign(folder, seed=seed)
    done = subprocess.run([sys.executable, "-m", "ogacq", "run", str(path), "--json"],
                          capture_output=True, text=True, timeout=180)
    assert done.returncode == 0, done.stderr
    return folder / "session.jsonl"


# what a session written before issue 15 does not hold
NEW_HEADER_KEYS = ("identity", "instruments", "date")
NEW_MACHINE_KEYS = ("name", "serial", "leg_expansion_ppm_per_k", "tolerances")


def as_before(source: Path, target: Path) -> Path:
    """``source``'s campaign as a session from before the record's context was
    recorded: no identity, instruments, date or temperatures (the same readings)."""
    old = load_session(source)
    header = {k: v for k, v in old.header.to_json().items()
              if k not in ("type", "format", "seq", "crc", *NEW_HEADER_KEYS)}
    header["machine"] = {k: v for k, v in header["machine"].items()
                         if k not in NEW_MACHINE_KEYS}
    if isinstance(header.get("simulator"), dict):
        header["simulator"] = {k: v for k, v in header["simulator"].items()
                               if k not in ("date", "simulated_date", "ambient_c")}
    with SessionWriter.create(target, header) as writer:
        for record in old.records:
            if not isinstance(record, EnvironmentRecord | OverrideRecord):
                writer.write(record)
    return target


def with_context(source: Path, target: Path, date: str = DATE) -> Path:
    """``source``'s campaign as a session recording its context: the header's
    identity, instruments and date, the environment at start and end, and the
    override of the expired y_x, around the same records."""
    old = load_session(source)
    header = {k: v for k, v in old.header.to_json().items()
              if k not in ("type", "format", "seq", "crc")}
    header["machine"] = {**header["machine"], "name": MACHINE_NAME, "serial": MACHINE_SERIAL,
                         "tolerances": {"deviation_mm": 0.02, "decision_rule": "guard-band"}}
    header |= {"identity": {"machine": MACHINE_NAME, "serial": MACHINE_SERIAL,
                            "operator": OPERATOR},
               "instruments": INSTRUMENTS, "date": date}
    with SessionWriter.create(target, header) as writer:
        writer.write(EnvironmentRecord(stage="start", ambient_c=20.4, machine_c=20.9,
                                       source="typed"))
        writer.write(OverrideRecord(what="expired-gauge", subject="y_x 12340000",
                                    due="2026-01-01", reason=OVERRIDE_REASON,
                                    operator=OPERATOR))
        for record in old.records:
            writer.write(record)
        writer.write(EnvironmentRecord(stage="end", ambient_c=21.1, machine_c=21.3,
                                       source="typed"))
    return target
