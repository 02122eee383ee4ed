"""``ogacq sim --axis-scales``: the simulator serves a scale along each named axis, each on
a line of its own, as ``calibrate --simulator`` does, and the campaign file that
``--write-campaign`` writes declares them (``[axis_scale.x]`` with their ports), so that
``ogacq positioning`` and ``ogacq calibrate`` rehearse against it."""

from __future__ import annotations

import os
import signal
import subprocess
import sys

from ogacq.campaign.campaign_file import read_campaign
from ogacq.campaign.station import open_gauges
from tests.cli.helpers import run_ogacq
from tests.interrupts import sigint_as_at_a_terminal


def test_sim_serves_the_scales_and_its_campaign_file_declares_them(tmp_path):
    campaign = tmp_path / "sim.toml"
    with sigint_as_at_a_terminal():  # the suite may run with SIGINT ignored
        sim = subprocess.Popen([sys.executable, "-m", "ogacq", "sim", "--axis-scales", "z,x",
                                "--write-campaign", str(campaign)], stdout=subprocess.PIPE,
                               stderr=subprocess.PIPE, text=True, start_new_session=True,
                               env={**os.environ, "COLUMNS": "1000"})  # one line each
    try:
        served = ""
        while "Ctrl-C" not in served:
            line = sim.stdout.readline()
            assert line, sim.stderr.read()
            served += line
        assert "x axis scale" in served and "z axis scale" in served
        assert f"ogacq positioning {campaign} --axis x" in " ".join(served.split())
        scales = read_campaign(campaign).axis_scales
        assert set(scales) == {"x", "z"} and scales["x"].port != scales["z"].port
        assert scales["x"].port in served and scales["x"].serial == "sim-scale-x"
        # read through the real codec on the line the file names
        with open_gauges([scales["x"].as_gauge("x")]) as indicators:
            reading = indicators["scale_x"].read(timeout_s=10.0)
        assert reading.frame.startswith(b"01A") and abs(reading.value_mm) < 1.0
    finally:
        os.killpg(sim.pid, signal.SIGINT)
        sim.wait(60)


def test_sim_refuses_a_scale_along_another_axis():
    refused = run_ogacq("sim", "--axis-scales", "x,w")
    assert refused.returncode == 2 and "--axis-scales" in refused.stderr \
        and "names axes x, y or z, got w" in refused.stderr
