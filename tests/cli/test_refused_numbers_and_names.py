"""Issue 36.6: numbers no campaign can have and names that do not show as they are
stored, refused in one line naming the option or the file's key (exit 2), before
anything is made; and a machine's name plotted as the text it is."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from ogacq.io.names import MAX_NAME_CHARACTERS
from tests.campaign.conftest import MACHINE
from tests.writeback.conftest import ogacq_here, synthetic_session

PAPER_MACHINE = Path(__file__).resolve().parents[2] / "ogacq" / "examples" / "paper" / \
    "machine.toml"


def one_line(stderr: str) -> str:
    lines = stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in stderr, stderr
    return lines[0]


@pytest.mark.parametrize(("option", "value"), [
    ("--noise", "1e308"), ("--cycles", str(10**40)), ("--trials", str(10**40)),
    ("--cycles", "1e40"), ("--trials", "1e40"), ("--assume", "joint_offset.x=1e308"),
    ("--assume", "squareness.xy=nan")])
def test_plan_refuses_numbers_no_campaign_can_have(option, value, capsys, monkeypatch):
    ran = ogacq_here(capsys, monkeypatch, "plan", "-m", PAPER_MACHINE, option, value,
                     "--trials" if option != "--trials" else "--cycles",
                     "0" if option != "--trials" else "1")
    assert ran.returncode == 2 and option in one_line(ran.stderr), ran.stderr


HOSTILE = {"escape": "A. Tech\x1b[2J", "line feed": "A. Tech\nM30", "nul": "A. Tech\x00",
           "long": "A" * 100_000, "line separator": "A. Tech\u2028M30",
           "right-to-left override": "A. Tech\u202egpj.exe"}


@pytest.mark.parametrize("name", sorted(HOSTILE))
def test_an_operator_that_is_no_name_is_refused(name, capsys, monkeypatch, tmp_path):
    value = HOSTILE[name]
    for command in (["calibrate", "--simulator", "--yes"], ["demo"]):
        out = tmp_path / command[0]
        ran = ogacq_here(capsys, monkeypatch, *command, "--operator", value, "--out", out,
                         "--history", "none")
        assert ran.returncode == 2 and "--operator" in one_line(ran.stderr), ran.stderr
        assert not out.exists()
    (tmp_path / "machine.toml").write_text(MACHINE)
    campaign = tmp_path / "campaign.toml"
    campaign.write_text(f'machine = "machine.toml"\noperator = {json.dumps(value)}\n'
                        '[simulator]\nseed = 1\n')
    ran = ogacq_here(capsys, monkeypatch, "run", campaign)
    line = one_line(ran.stderr)
    assert ran.returncode == 2 and "campaign.toml:2: operator" in line, line
    assert not (tmp_path / "s.jsonl").exists()


@pytest.mark.parametrize("char", ["\u2028", "\u202e", "\u2029", "\x00"])
def test_a_machine_name_that_does_not_show_as_stored_is_refused(char, capsys, monkeypatch,
                                                               tmp_path):
    machine = tmp_path / "machine.toml"
    machine.write_text(f'name = {json.dumps(f"cell{char} 3")}\n{MACHINE}')
    ran = ogacq_here(capsys, monkeypatch, "plan", "-m", machine, "--trials", "0")
    line = one_line(ran.stderr)
    assert ran.returncode == 2 and "machine.toml:1: name" in line and \
        f"U+{ord(char):04X}" in line, line
    machine.write_text(f'name = "{"n" * (MAX_NAME_CHARACTERS + 1)}"\n{MACHINE}')
    ran = ogacq_here(capsys, monkeypatch, "plan", "-m", machine, "--trials", "0")
    assert ran.returncode == 2 and "at most 200" in one_line(ran.stderr)


def test_the_history_plot_shows_a_name_holding_dollars_as_text(capsys, monkeypatch,
                                                                tmp_path):
    name = r"cell $\frac{$ 3"
    (tmp_path / "campaign.toml").write_text("")
    session = synthetic_session(
        tmp_path / "s.jsonl", tmp_path / "campaign.toml", offsets_mm={"x": 0.1},
        header_extra={"machine": {"leg_length_mm": 310.25, "rho_min_mm": -100.0,
                                  "rho_max_mm": 60.0, "gauge_resolution_mm": 0.001,
                                  "name": name}})
    assert ogacq_here(capsys, monkeypatch, "history", "add", session).returncode == 0
    plot = tmp_path / "history.png"
    ran = ogacq_here(capsys, monkeypatch, "history", name, "--plot", plot)
    assert ran.returncode == 0, ran.stderr
    assert plot.read_bytes()[:4] == b"\x89PNG"


def test_an_effects_file_with_a_screw_lead_no_screw_has_is_refused(capsys, monkeypatch,
                                                                     tmp_path):
    effects = tmp_path / "effects.toml"
    effects.write_text("[lead_screw.x]\namplitude_mm = 0.002\npitch_mm = 1e-9\n")
    out = tmp_path / "demo"
    ran = ogacq_here(capsys, monkeypatch, "demo", "--effects", effects, "--out", out)
    line = one_line(ran.stderr)
    assert ran.returncode == 2 and "effects.toml:3: lead_screw.x.pitch_mm" in line, line
    assert not out.exists()


def test_a_gauge_identity_that_does_not_show_as_stored_is_refused(capsys, monkeypatch,
                                                                   tmp_path):
    (tmp_path / "machine.toml").write_text(MACHINE)
    campaign = tmp_path / "campaign.toml"
    serial = json.dumps("SN 12\u202e34")
    campaign.write_text('machine = "machine.toml"\n[simulator]\nseed = 1\n\n[[gauges]]\n'
                        f'gauge = "y_x"\nserial = {serial}\n')
    ran = ogacq_here(capsys, monkeypatch, "run", campaign)
    line = one_line(ran.stderr)
    assert ran.returncode == 2 and "campaign.toml:7:" in line and "serial" in line and \
        "U+202E" in line, line
