"""Records shaped as docs/calibration-record.md section 5 says (``ogacq-record/1``),
built here for the store's tests: the history is written and read against the
contract, whatever builds the records."""

from __future__ import annotations

import hashlib
from typing import Any

AXES = ("x", "y", "z")


def contract_record(*, date: str = "2026-01-10T09:00:00", machine: str = "OG-1 cell 3",
                    serial: str = "OG-2026-0017", operator: str = "J. Martin",
                    offsets: dict[str, float] | None = None, U: float | None = 0.006,
                    u: float | None = 0.003, std: float | None = 0.0028,
                    ambient_c: float | None = 20.4,
                    decision: str = "pass", session: str = "/runs/a/session.jsonl",
                    consistent: bool = True) -> dict[str, Any]:
    offsets = offsets or {"x": 0.42, "y": -0.31, "z": 0.12}
    digest = hashlib.sha256(f"{machine}{serial}{date}".encode()).hexdigest()
    record_id = f"OGQ-{date[:10].replace('-', '')}-{digest[:8]}"
    return {
        "format": "ogacq-record/1",
        "id": record_id,
        "issued": f"{date}+01:00",
        "machine": {"name": machine, "serial": serial, "file": {"leg_length_mm": 310.25}},
        "operator": operator,
        "date": date,
        "instruments": [{"gauge": "y_x", "make": "Mitutoyo", "model": "543-790B",
                         "serial": "12345678", "certificate": "DKD-K-12345 2026-0412",
                         "calibrated": "2026-03-01", "due": "2027-03-01",
                         "uncertainty_mm": 0.0015, "uncertainty_k": 2.0, "expired": False}],
        "environment": {"start": {"ambient_c": ambient_c, "machine_c": None,
                                  "source": "typed"},
                        "end": {"ambient_c": ambient_c, "machine_c": None, "source": "typed"}},
        "method": {"protocol": {"cycles": 3}, "params": "offsets", "software": "ogacq 0.1.0",
                   "decision_rule": "guard-band"},
        "results": {"joint_offset": {a: {"value_mm": v, "std_mm": std, "u_mm": u, "U_mm": U,
                                         "k": 2.0 if U is not None else None, "unit": "mm"}
                                     for a, v in offsets.items()}},
        "budget": {}, "budget_complete": U is not None,
        "monte_carlo": {"draws": 2000, "u_mm": {}, "agreement": 0.04},
        "acceptance": {"rule": "guard-band", "as_found": {"decision": decision, "rows": []},
                       "as_left": {"decision": "not evaluated",
                                   "why": "no as-left measurement"}},
        "verdict": {"consistent": consistent, "chi2_dof": 1.1, "p": 0.36},
        "overrides": [],
        "writeback": [],
        "session": {"path": session, "sha256": digest, "records": 80},
    }
