"""``ogacq offsets restore --machine NAME --to STATE`` against a real ``ogacq sim``
process: two write-backs recorded in the history, then back to the first one's
offsets through the usual write-back (plan, confirmation, read-back, audit), the
restore recorded in turn; a controller changed outside the history is refused."""

from __future__ import annotations

import json

import pytest

from ogacq.campaign.campaign_file import read_campaign
from ogacq.campaign.station import open_controller
from ogacq.model.parameters import AXES
from ogacq.session.records import OffsetsRecord
from ogacq.session.store import load_session
from tests.writeback.conftest import (
    controller_offsets,
    ogacq_here,
    sim_campaign,
    simulator,
    synthetic_session,
)

NAME = "OG-restore"
IDENTITY = {"identity": {"machine": NAME, "serial": "SIM-7", "operator": "B. Metrologist"},
            "date": "2026-04-01T09:00:00"}


def close(a: dict, b: dict, tol: float = 1.5e-3) -> bool:
    return all(abs(a[k] - b[k]) <= tol for k in AXES)


@pytest.mark.slow
def test_back_to_any_recorded_state(tmp_path, capsys, monkeypatch):
    history = tmp_path / "history.sqlite"

    def ogacq(*args, stdin=""):
        return ogacq_here(capsys, monkeypatch, *args, "--history", history, stdin=stdin)

    def states():
        ran = ogacq("history", NAME, "--states", "--json")
        assert ran.returncode == 0, ran.stderr
        return json.loads(ran.stdout)

    with simulator(tmp_path, "cia402", 3) as info:
        campaign = sim_campaign(tmp_path, info, name="cal")
        zeros = dict.fromkeys(AXES, 0.0)
        first = synthetic_session(tmp_path / "first.jsonl", campaign,
                                  offsets_mm={"x": 0.30, "y": -0.20, "z": 0.10},
                                  header_extra=IDENTITY)
        wrote = ogacq("offsets", "write", first, "--yes", "--no-home")
        assert wrote.returncode == 0, wrote.stderr
        assert "history: 1 calibration, 1 write-back recorded" in wrote.stderr
        after_first = controller_offsets(campaign)
        assert close(after_first, {"x": -0.30, "y": 0.20, "z": -0.10}, 0.01)
        second = synthetic_session(tmp_path / "second.jsonl", campaign, seed=1,
                                   offsets_mm={"x": 0.05, "y": 0.04, "z": -0.03},
                                   in_force_mm=after_first,
                                   header_extra={**IDENTITY, "date": "2026-05-01T09:00:00"})
        assert ogacq("offsets", "write", second, "--yes", "--no-home").returncode == 0
        listed = states()
        assert [s["stage"] for s in listed["states"]] == ["before", "after"] * 2
        assert listed["in_force"] == listed["states"][3]["state"]
        first_record = listed["states"][1]["record"]

        # back to the first calibration's write-back, by its record id
        back = ogacq("offsets", "restore", "--machine", NAME, "--to", first_record, "--yes",
                     "--no-home")
        assert back.returncode == 0, back.stderr
        assert close(controller_offsets(campaign), after_first, 1e-6)
        audit = load_session(first).of_type(OffsetsRecord)
        assert [r.stage for r in audit][-2:] == ["intent", "done"]  # the usual audit
        assert audit[-2].details["restores"] == listed["states"][1]["state"]
        now = states()
        assert len(now["states"]) == 6 and now["states"][-1]["action"] == "restore"
        assert now["in_force"] == now["states"][-1]["state"]

        # the controller changed behind the history's back: going back is refused
        with open_controller(read_campaign(campaign).controller) as controller:
            controller.write_offsets({"x": -0.1, "y": 0.0, "z": 0.0})
        before_all = listed["states"][0]["state"]
        refused = ogacq("offsets", "restore", "--machine", NAME, "--to", before_all, "--yes",
                        "--no-home")
        assert refused.returncode == 4
        assert "stale" in refused.stdout + refused.stderr
        assert close(controller_offsets(campaign), {"x": -0.1, "y": 0.0, "z": 0.0}, 1e-6)
        forced = ogacq("offsets", "restore", "--machine", NAME, "--to", before_all, "--yes",
                       "--no-home", "--force")
        assert forced.returncode == 0, forced.stderr
        assert close(controller_offsets(campaign), zeros, 1e-6)
