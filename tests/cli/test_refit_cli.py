"""``ogacq refit`` as users and scripts call it: the published figures and bad input."""

import json
import re

import numpy as np
import pytest

from tests.cli.helpers import run_ogacq


def refit_json(paper_dir, name, params):
    return run_ogacq("refit", paper_dir / f"{name}.csv", "--machine",
                     paper_dir / "machine.toml", "--params", params, "--json", check_json=True)


def test_exp2_offsets_json_contract(paper_dir):
    out = refit_json(paper_dir, "experiment2_12", "offsets")
    assert set(out) == {"params", "parameters", "std", "residual_rms_mm", "sigma_mm", "dof",
                        "condition_number", "identifiable", "correlated_pairs"}
    assert out["params"] == "offsets"
    got = [out["parameters"]["joint_offset"][a] for a in "xyz"]
    assert np.allclose(got, [-0.49, 0.50, -1.67], atol=0.02)
    assert out["residual_rms_mm"] == pytest.approx(0.138, abs=0.001)
    assert out["sigma_mm"] == pytest.approx(0.16, abs=0.005)
    assert out["dof"] == 9
    assert out["condition_number"] == pytest.approx(1.47, abs=0.01)
    assert out["identifiable"] is True and out["correlated_pairs"] == []
    assert all(s == pytest.approx(0.021, abs=0.001) for s in out["std"]["joint_offset"].values())


def test_exp2_lengths_and_both_json(paper_dir):
    lengths = refit_json(paper_dir, "experiment2_12", "lengths")
    assert np.allclose([lengths["parameters"]["leg_length"][a] for a in "xyz"],
                       [0.49, -0.52, 1.69], atol=0.02)
    both = refit_json(paper_dir, "experiment2_12", "both")
    assert both["residual_rms_mm"] == pytest.approx(0.126, abs=0.001)
    assert both["identifiable"] is False
    named = {tuple(sorted(p[:2])) for p in both["correlated_pairs"]}
    assert ("joint_offset.x", "leg_length.x") in named
    assert all(abs(p[2]) > 0.99 for p in both["correlated_pairs"])


def test_exp1_json_and_six_equation_rank(paper_dir):
    exp1 = refit_json(paper_dir, "experiment1_6", "offsets")
    assert exp1["residual_rms_mm"] == pytest.approx(0.76, abs=0.005)
    assert exp1["sigma_mm"] == pytest.approx(1.07, abs=0.01)
    both = refit_json(paper_dir, "experiment2_6", "both")
    assert both["identifiable"] is False
    assert json.dumps(both)  # no NaN or Infinity in what scripts read


def test_human_table_names_the_verdict(paper_dir):
    proc = run_ogacq("refit", paper_dir / "experiment2_12.csv", "--machine",
                     paper_dir / "machine.toml", "--params", "both")
    assert proc.returncode == 0, proc.stderr
    assert "not identifiable" in proc.stdout
    assert "joint_offset.x" in proc.stdout
    # a standard deviation has no sign
    assert re.search(r"sigma from residuals \d+\.\d+ mm", " ".join(proc.stdout.split()))


def _machine(tmp_path, text):
    path = tmp_path / "m.toml"
    path.write_text(text)
    return path


GOOD_MACHINE = ("leg_length_mm = 310.25\nrho_min_mm = -100.0\nrho_max_mm = 60.0\n"
                "gauge_resolution_mm = 0.01\n")
READINGS_HEADER = "t_s,cycle,leg,gauge_axis,tcp_x,tcp_y,tcp_z,q_x,q_y,q_z,reading_mm\n"
GOOD_ROW = "0.0,1,x,y,0,0,0,0,0,0,1.234\n"


@pytest.mark.parametrize(("csv_text", "line", "words"), [
    ("name,value\ndx_y+,0.1\n", 1, "no unit"),
    ("name,value_in\ndx_y+,0.1\n", 1, "inches"),
    ("name,value_mm\ndx_q+,0.1\n", 2, "not a deviation name"),
    ("name,value_mm\ndx_y+,0.1\ndy_x+,abc\n", 3, "not a number"),
    ("name,value_mm\ndx_y+,0.1\ndx_y+,0.2\n", 3, "twice"),
    (READINGS_HEADER.replace("reading_mm", "reading") + GOOD_ROW, 1, "no unit"),
    (READINGS_HEADER.replace(",leg,", ",legs,") + GOOD_ROW, 1, "missing column 'leg'"),
    (READINGS_HEADER + GOOD_ROW + "1.0,1,x,x,0,0,0,0,0,0,1.2\n", 3, "equals leg"),
    (READINGS_HEADER + GOOD_ROW + "1.0,0,x,y,0,0,0,0,0,0,1.2\n", 3, "cycle"),
    (READINGS_HEADER + GOOD_ROW + "1.0,1,x,y,0,0,0,0,0,0,\n", 3, "not a number"),
    (READINGS_HEADER + GOOD_ROW + "1.0,1,x,y,250,0,0,250,0,0,1.2\n", 3, "outside the workspace"),
    (READINGS_HEADER + GOOD_ROW + "1.0,1,w,y,0,0,0,0,0,0,1.2\n", 3, "not one of x, y, z"),
    ("foo,bar\n1,2\n", 1, "unrecognised header"),
])
def test_bad_data_file_one_line_exit_2(tmp_path, csv_text, line, words):
    data = tmp_path / "data.csv"
    data.write_text(csv_text)
    proc = run_ogacq("refit", data, "--machine", _machine(tmp_path, GOOD_MACHINE))
    assert proc.returncode == 2, proc.stdout
    message = proc.stderr.strip()
    assert len(message.splitlines()) == 1, message
    assert "Traceback" not in proc.stderr
    assert f"{data}:{line}:" in message
    assert words in message


@pytest.mark.parametrize(("machine_text", "words", "line"), [
    ("leg_length_mm = 310.25\nrho_min_mm = -100.0\nrho_max_mm = 60.0\n", "gauge_resolution_mm",
     None),
    (GOOD_MACHINE + "leg_length = 3\n", "unknown key 'leg_length'", 5),
    (GOOD_MACHINE.replace("60.0", '"sixty"'), "must be a number", 3),
    (GOOD_MACHINE.replace("60.0", "400.0"), "impossible geometry", 3),
    ("leg_length_mm = = 3\n", "not valid TOML", 1),
])
def test_bad_machine_file_one_line_exit_2(tmp_path, paper_dir, machine_text, words, line):
    machine = _machine(tmp_path, machine_text)
    proc = run_ogacq("refit", paper_dir / "experiment2_12.csv", "--machine", machine)
    assert proc.returncode == 2
    message = proc.stderr.strip()
    assert len(message.splitlines()) == 1 and "Traceback" not in proc.stderr
    assert str(machine) in message and words in message
    if line is not None:
        assert f"{machine}:{line}:" in message


def test_missing_files_named(tmp_path, paper_dir):
    proc = run_ogacq("refit", tmp_path / "nope.csv", "--machine", paper_dir / "machine.toml")
    assert proc.returncode == 2 and "nope.csv: no such file" in proc.stderr
    proc = run_ogacq("refit", paper_dir / "experiment2_12.csv", "--machine",
                     tmp_path / "none.toml")
    assert proc.returncode == 2 and "none.toml" in proc.stderr


def test_plan_json(paper_dir):
    # a gauge noise to draw trials with: the papers' machine states none (issue 38)
    out = run_ogacq("plan", "--machine", paper_dir / "machine.toml", "--trials", "500",
                    "--noise", "0.005", "--json", check_json=True)
    std = out["analytic_std"]["joint_offset.x"]
    assert std == pytest.approx(out["monte_carlo"]["std"]["joint_offset.x"], rel=0.15)
    assert out["identifiable"] is True and out["readings"] == 72
