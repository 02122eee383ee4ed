"""The files a user starts from and writes to: `ogacq init` templates that load back,
the examples shipped in the package, a campaign file that talks to `ogacq sim`, and
output files that are replaced only with --force."""

from __future__ import annotations

import json
import os
import select
import signal
import socket
import subprocess
import sys
from pathlib import Path

import pytest

from ogacq.campaign.campaign_file import read_campaign
from ogacq.campaign.templates import campaign_template, machine_template
from ogacq.cli.app import main
from ogacq.io.machine_file import read_machine
from ogacq.model.gauges import GAUGE_KEYS
from ogacq.model.machine import PAPER_PROTOTYPE
from tests.cli.helpers import run_ogacq
from tests.interrupts import sigint_as_at_a_terminal

EXAMPLES = Path(__file__).resolve().parents[2] / "ogacq" / "examples"


def test_init_templates_load_back(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert main(["init", "machine"]) == 0
    assert main(["init", "campaign", "cal.toml"]) == 0
    machine = read_machine(tmp_path / "machine.toml")
    assert (machine.leg_length_mm, machine.rho_min_mm, machine.rho_max_mm,
            machine.gauge_resolution_mm) == (PAPER_PROTOTYPE.leg_length_mm,
                                             PAPER_PROTOTYPE.rho_min_mm,
                                             PAPER_PROTOTYPE.rho_max_mm,
                                             PAPER_PROTOTYPE.gauge_resolution_mm)
    campaign = read_campaign(tmp_path / "cal.toml")
    assert campaign.machine_path == tmp_path / "machine.toml"
    assert sorted(g.gauge for g in campaign.gauges) == sorted(GAUGE_KEYS)
    assert campaign.controller is not None and campaign.simulator is None
    assert "# leg_length_mm" in (tmp_path / "machine.toml").read_text()  # commented


def test_init_overwrites_only_with_force(tmp_path, capsys):
    target = tmp_path / "machine.toml"
    target.write_text("mine\n")
    assert main(["init", "machine", str(target)]) == 2
    assert "--force" in capsys.readouterr().err and target.read_text() == "mine\n"
    assert main(["init", "machine", str(target), "--force"]) == 0
    assert target.read_text() == machine_template()


def test_the_shipped_examples_are_the_templates():
    campaign_path = EXAMPLES / "campaign.toml"
    assert (EXAMPLES / "machine.toml").read_text() == machine_template()
    assert campaign_path.read_text() == campaign_template(campaign_path,
                                                          EXAMPLES / "machine.toml")
    assert read_campaign(campaign_path).machine == read_machine(EXAMPLES / "machine.toml")


def test_session_import_makes_no_folder(tmp_path, capsys):
    out = tmp_path / "nonexistent" / "s.jsonl"
    code = main(["session", "import", str(EXAMPLES / "paper" / "experiment2_12.csv"),
                 str(out), "-m", str(EXAMPLES / "paper" / "machine.toml")])
    assert code == 2 and f"no folder {out.parent}" in capsys.readouterr().err
    assert not out.parent.exists()


@pytest.mark.slow
def test_a_campaign_written_by_sim_runs_against_it(tmp_path):
    """`ogacq sim --port N --write-campaign FILE`, then `ogacq run FILE`; the session
    exports to a readings CSV that is replaced only with --force."""
    campaign = tmp_path / "sim.toml"
    with sigint_as_at_a_terminal():  # stopped by Ctrl-C below
        sim = subprocess.Popen([sys.executable, "-m", "ogacq", "sim", "--json", "--speed",
                                "100", "--port", str(_free_port()), "--write-campaign",
                                str(campaign)], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                               text=True, start_new_session=True)
    try:
        ready, _, _ = select.select([sim.stdout], [], [], 30)
        assert ready, "ogacq sim printed nothing"
        info = json.loads(sim.stdout.readline())
        assert read_campaign(campaign).controller.port == \
            f"{info['modbus']['host']}:{info['modbus']['port']}"
        run = run_ogacq("run", campaign, "--json", timeout=120)
        assert run.returncode == 0, run.stderr
    finally:
        os.killpg(sim.pid, signal.SIGINT)
        try:  # a sim deaf to Ctrl-C fails the test; a slow one on a busy machine does not
            sim.wait(60)
        except subprocess.TimeoutExpired:
            os.killpg(sim.pid, signal.SIGKILL)
            sim.wait(10)
            raise
    session = tmp_path / "sessions" / "sim.jsonl"
    csv = tmp_path / "readings.csv"
    csv.write_text("old\n")
    refused = run_ogacq("session", "export", session, csv)
    assert refused.returncode == 2 and "--force" in refused.stderr
    assert csv.read_text() == "old\n"
    replaced = run_ogacq("session", "export", session, csv, "--force")
    assert replaced.returncode == 0, replaced.stderr
    assert csv.read_text().startswith("t_s,") and len(csv.read_text().splitlines()) == 73


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]
