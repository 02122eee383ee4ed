"""``ogacq run`` against the built-in simulator, through the real drivers."""

import numpy as np
import pytest

from ogacq.session.store import load_session
from tests.campaign.conftest import write_campaign
from tests.cli.helpers import run_ogacq


@pytest.mark.parametrize(("profile", "seed"), [("cia402", 3), ("iai-pcon", 8)])
def test_run_recovers_hidden_offsets_within_predicted_std(campaign_dir, profile, seed):
    path = write_campaign(campaign_dir, seed=seed, profile=profile)
    out = run_ogacq("run", path, "--json", check_json=True)
    hidden = out["hidden"]
    got = out["parameters"]["joint_offset"]
    std = out["std"]["joint_offset"]
    for axis in "xyz":
        truth = hidden[f"joint_offset.{axis}"]
        assert abs(truth) > 0.05  # there was something to find
        assert abs(got[axis] - truth) < 3 * std[axis], (axis, got[axis], truth, std[axis])
        assert std[axis] < 0.002
    session = load_session(campaign_dir / "session.jsonl")
    assert session.finished
    assert len(session.readings) == 72
    # the session names its station: protocol, ports and the software version
    assert session.header["software"].startswith("ogacq ")
    assert session.header["station"]["controller"]["profile"] == profile
    assert len(session.header["station"]["gauges"]) == 6
    # every reading kept its raw frame and where it came from
    assert all(r["raw"].startswith("01A") and r["source"] for r in session.readings)


def test_refit_reads_the_session_and_its_csv_export(campaign_dir, tmp_path):
    path = write_campaign(campaign_dir, seed=5)
    run_ogacq("run", path, "--json", check_json=True)
    session_path = campaign_dir / "session.jsonl"
    machine = campaign_dir / "machine.toml"
    from_session = run_ogacq("refit", session_path, "--machine", machine, "--json",
                             check_json=True)
    from ogacq.io.machine_file import read_machine
    from ogacq.session.convert import export_readings, import_readings

    csv_path = tmp_path / "readings.csv"
    assert export_readings(load_session(session_path), csv_path) == 72
    from_csv = run_ogacq("refit", csv_path, "--machine", machine, "--json", check_json=True)
    a = from_session["parameters"]["joint_offset"]
    b = from_csv["parameters"]["joint_offset"]
    assert np.allclose([a[k] for k in "xyz"], [b[k] for k in "xyz"], atol=1e-6)
    # and back: a session imported from the CSV holds the same readings
    back = import_readings(csv_path, read_machine(machine), tmp_path / "imported.jsonl")
    again = run_ogacq("refit", back, "--machine", machine, "--json", check_json=True)
    c = again["parameters"]["joint_offset"]
    assert np.allclose([a[k] for k in "xyz"], [c[k] for k in "xyz"], atol=1e-6)
