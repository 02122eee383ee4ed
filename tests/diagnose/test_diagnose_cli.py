"""``ogacq diagnose``: the JSON contract of INTERCHANGE.md, the terminal account and
one-line errors."""

from __future__ import annotations

import re

import pytest

from ogacq.io.tables import write_readings
from tests.cli.helpers import run_ogacq
from tests.diagnose.campaigns import simulate

MACHINE_TOML = """leg_length_mm = 310.25
rho_min_mm = -100.0
rho_max_mm = 60.0
gauge_resolution_mm = 0.001
gauge_repeatability_mm = 0.002
"""


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    root = tmp_path_factory.mktemp("diagnose")
    (root / "m.toml").write_text(MACHINE_TOML)
    for name, effects in (("square", {"squareness.xy": 0.4}), ("clean", {})):
        obs = simulate(effects, 21)
        write_readings(root / f"{name}.csv", obs.layout, obs.values)
    return root


def test_json_contract(files):
    out = run_ogacq("diagnose", files / "square.csv", "--machine", files / "m.toml", "--json",
                    check_json=True)
    contract = {"noise_mm", "base", "final", "located", "effects", "parameters"}
    # keys beyond INTERCHANGE.md's may only be added (the maps' search and results)
    assert contract <= set(out)
    assert set(out) - contract <= {"maps", "proposals", "coverage", "chi2", "profiles",
                                   "unknown_sides", "outliers"}
    assert set(out["base"]) == set(out["final"]) == {"chi2_dof", "rms_mm", "consistent"}
    assert out["base"]["consistent"] is False and out["final"]["consistent"] is True
    assert out["noise_mm"] == pytest.approx(0.00202, abs=1e-5)
    assert out["final"]["rms_mm"] < out["base"]["rms_mm"]
    assert all(set(g) == {"leg", "gauge_axis", "share"} for g in out["located"])
    [effect] = out["effects"]
    assert set(effect) == {"effect", "where", "value", "std", "unit", "alternatives"}
    assert (effect["effect"], effect["where"], effect["unit"]) == ("squareness", "xy", "mrad")
    assert abs(effect["value"] - 0.4) < 4 * effect["std"]
    assert effect["alternatives"] == []
    assert set(out["parameters"]) == {"joint_offset"}
    assert set(out["parameters"]["joint_offset"]) == {"x", "y", "z"}


def test_consistent_campaign_json(files):
    out = run_ogacq("diagnose", files / "clean.csv", "--machine", files / "m.toml", "--json",
                    check_json=True)
    assert out["base"]["consistent"] and out["effects"] == []


def test_terminal_account(files):
    proc = run_ogacq("diagnose", files / "square.csv", "--machine", files / "m.toml")
    assert proc.returncode == 0, proc.stderr
    text = " ".join(proc.stdout.split())
    assert "NOT within the gauge noise" in text and "p =" in text
    assert "Where the misfit" in text
    assert "squareness.xy" in text and "Search:" in text  # the search table shown
    assert re.search(r"(?<!NOT )within the gauge noise", text)  # with the squareness


def test_papers_experiment1(paper_dir):
    out = run_ogacq("diagnose", paper_dir / "experiment1_6.csv", "--machine",
                    paper_dir / "machine.toml", "--json", check_json=True)
    assert out["noise_mm"] == 0.01
    assert out["base"]["consistent"] is False
    assert out["effects"][-1]["effect"] == "unexplained"
    proc = run_ogacq("diagnose", paper_dir / "experiment2_6.csv", "--machine",
                     paper_dir / "machine.toml")
    text = " ".join(proc.stdout.split())
    assert "cannot be told apart" in text and "not seen at all" in text
    assert "reproduce these data exactly" in text


def test_bad_file_is_one_line_error(files, tmp_path):
    proc = run_ogacq("diagnose", tmp_path / "missing.csv", "--machine", files / "m.toml")
    assert proc.returncode == 2
    assert proc.stderr.startswith("ogacq: error:") and "missing.csv" in proc.stderr
    assert "Traceback" not in proc.stderr
