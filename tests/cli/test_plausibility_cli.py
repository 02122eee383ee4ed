"""A session is analysed with its own machine; data that cannot be millimetres of this
machine, or too few for the parameters asked, are refused with one line, exit 2."""

from __future__ import annotations

import json

import pytest

from ogacq.io.tables import write_readings
from tests.cli.helpers import run_ogacq
from tests.diagnose.campaigns import simulate
from tests.diagnose.test_diagnose_cli import MACHINE_TOML

OTHER_TOML = MACHINE_TOML.replace("leg_length_mm = 310.25", "leg_length_mm = 250.0")


@pytest.fixture(scope="module")
def session(tmp_path_factory):
    root = tmp_path_factory.mktemp("plausible")
    (root / "m.toml").write_text(MACHINE_TOML)
    (root / "other.toml").write_text(OTHER_TOML)
    obs = simulate({}, 3)
    write_readings(root / "r.csv", obs.layout, obs.values)
    proc = run_ogacq("session", "import", root / "r.csv", root / "s.jsonl", "--machine",
                     root / "m.toml")
    assert proc.returncode == 0, proc.stderr
    return root


def one_line_error(proc) -> str:
    assert proc.returncode == 2, (proc.stdout, proc.stderr)
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in proc.stderr, proc.stderr
    return lines[0]


def test_a_session_is_analysed_with_its_own_machine(session):
    own = run_ogacq("refit", session / "s.jsonl", "--json", check_json=True)
    named = run_ogacq("refit", session / "s.jsonl", "--machine", session / "m.toml", "--json",
                      check_json=True)
    assert own == named
    diagnosed = run_ogacq("diagnose", session / "s.jsonl", "--json", check_json=True)
    assert diagnosed["base"]["consistent"] is True


@pytest.mark.parametrize("command", ["refit", "diagnose"])
def test_another_machines_file_is_refused_naming_the_keys(session, command):
    line = one_line_error(run_ogacq(command, session / "s.jsonl", "--machine",
                                    session / "other.toml"))
    assert "other.toml" in line and "leg_length_mm 250.0 there, 310.25 in the session" in line
    assert "--other-geometry" in line
    # said on purpose, it is a reanalysis with that geometry
    proc = run_ogacq(command, session / "s.jsonl", "--machine", session / "other.toml",
                     "--other-geometry", "--json")
    assert proc.returncode == 0, proc.stderr


def test_a_csv_needs_its_machine(session):
    line = one_line_error(run_ogacq("refit", session / "r.csv"))
    assert "r.csv" in line and "--machine" in line


def test_micrometres_in_a_mm_column_are_refused(paper_dir, tmp_path):
    rows = (paper_dir / "experiment2_12.csv").read_text().splitlines()
    scaled = [rows[0]] + [f"{r.split(',')[0]},{float(r.split(',')[1]) * 1000:.1f}"
                          for r in rows[1:]]
    (tmp_path / "um.csv").write_text("\n".join(scaled) + "\n")
    for command in ("refit", "diagnose"):
        line = one_line_error(run_ogacq(command, tmp_path / "um.csv", "--machine",
                                        paper_dir / "machine.toml"))
        assert "um.csv" in line and "travel" in line and "µm" in line


def test_too_few_data_for_the_parameters_are_refused(paper_dir, tmp_path):
    (tmp_path / "one.csv").write_text("name,value_mm\ndx_y+,0.12\n")
    line = one_line_error(run_ogacq("refit", tmp_path / "one.csv", "--machine",
                                    paper_dir / "machine.toml"))
    assert "one.csv" in line and "1 deviations for 3 parameters" in line


def test_offsets_beyond_the_machine_are_refused(paper_dir, tmp_path):
    """Deviations a gauge could read, but offsets no machine of this leg could have."""
    (tmp_path / "far.csv").write_text(
        "name,value_mm\n" + "".join(f"d{a}_{b}{s},{v}\n" for a, b in
                                    (("x", "y"), ("y", "x"), ("x", "z"), ("z", "x"))
                                    for s, v in (("+", 30.0), ("-", -45.0))))
    line = one_line_error(run_ogacq("refit", tmp_path / "far.csv", "--machine",
                                    paper_dir / "machine.toml"))
    assert "far.csv" in line and "beyond 5% of the 310.25 mm leg" in line


def test_the_json_contract_is_unchanged_by_the_checks(session):
    out = json.loads(run_ogacq("diagnose", session / "s.jsonl", "--json").stdout)
    assert set(out["base"]) == {"chi2_dof", "rms_mm", "consistent"}


@pytest.mark.parametrize(("value", "words"), [("inf", "finite number"), ("1e308", "at most")])
def test_a_machine_file_with_an_impossible_length_is_refused(paper_dir, tmp_path, value, words):
    text = (paper_dir / "machine.toml").read_text()
    (tmp_path / "m.toml").write_text(text.replace("leg_length_mm = 310.25",
                                                  f"leg_length_mm = {value}"))
    line = one_line_error(run_ogacq("refit", paper_dir / "experiment2_12.csv", "--machine",
                                    tmp_path / "m.toml"))
    assert "m.toml:" in line and "leg_length_mm" in line and words in line
