"""A new gauge protocol is one module: ``throwaway_gauge.py`` (its codec, driver,
simulated instrument and hints), registered here and nowhere else, runs a campaign
end to end on the simulated machine (its simulated gauges on real pseudo-terminals,
read by its driver through the station as any campaign reads its gauges), shows the
simulator's faults, and the wizard shows its hints."""

from __future__ import annotations

import io
from collections.abc import Iterator
from pathlib import Path

import pytest
from rich.console import Console

from ogacq_drivers.errors import DeviceFault
from ogacq_drivers.indicators import BACKENDS, codec, open_indicator, registered
from ogacq_drivers.sim.gauges import Fault, GaugeEndpoint
from ogacq.campaign.campaign_file import read_campaign
from ogacq.campaign.run import run_campaign
from ogacq.cli.wizard.connect import show_hints
from ogacq.cli.wizard.ui import Screen
from ogacq.errors import InputError
from ogacq.io.machine_file import write_machine
from ogacq.model.machine import MachineSpec
from ogacq.session.store import load_session
from tests.drivers import throwaway_gauge
from tests.drivers.backend_parts import missing_parts

MACHINE = MachineSpec(310.25, -100.0, 60.0, gauge_resolution_mm=0.001)


@pytest.fixture
def throwaway() -> Iterator[str]:
    with registered("throwaway", throwaway_gauge.BACKEND):
        yield "throwaway"


def test_the_new_protocol_has_every_part(throwaway: str):
    assert missing_parts(throwaway, BACKENDS[throwaway]) == []
    for example in codec(throwaway).examples:  # its codec reads its own examples
        if example.value_mm is not None:
            assert codec(throwaway).decode(example.frame).value_mm() == example.value_mm


CAMPAIGN_FILE = """machine = "machine.toml"
session = "session.jsonl"
[protocol]
cycles = 1
settle = "fixed"
settle_s = 0.05
[simulator]
seed = 3
speed = 50
noise_mm = 0.0005
gauge_protocol = "throwaway"
gauge_protocols = { z_y = "throwaway" }
"""


def test_the_new_protocol_runs_a_campaign_file_end_to_end(throwaway: str, tmp_path: Path):
    """A campaign file names it as it names any protocol: the file's schema takes the
    protocols registered when the file is read (campaign_file.py was imported above,
    before the registration)."""
    write_machine(tmp_path / "machine.toml", MACHINE, "the throwaway protocol's test")
    (tmp_path / "campaign.toml").write_text(CAMPAIGN_FILE)
    campaign = read_campaign(tmp_path / "campaign.toml")
    assert campaign.simulator is not None and campaign.simulator.gauge_protocol == throwaway
    outcome = run_campaign(campaign)
    session = load_session(outcome.session_path)
    assert session.finished and len(session.readings) == 24
    assert {g["protocol"] for g in session.header.station["gauges"].values()} == {throwaway}
    assert all((r.raw or "").startswith("VAL=") for r in session.readings)  # its frames, recorded
    assert outcome.hidden is not None
    for index, name in enumerate(outcome.fit.names):  # the readings were read right
        error = outcome.fit.values[index] - outcome.hidden[name]
        assert abs(error) < max(5 * outcome.fit.std[index], 0.003), name


def test_a_campaign_file_names_only_a_registered_protocol(tmp_path: Path):
    """Unregistered again, the same file is refused, every place that names it."""
    write_machine(tmp_path / "machine.toml", MACHINE, "the throwaway protocol's test")
    path = tmp_path / "campaign.toml"
    path.write_text(CAMPAIGN_FILE)
    with registered("throwaway", throwaway_gauge.BACKEND):
        read_campaign(path)
    assert "throwaway" not in BACKENDS
    with pytest.raises(InputError, match=r"campaign\.toml:11: simulator\.gauge_protocol must "
                                         r"be one of mitutoyo-01a, .*, got 'throwaway'"):
        read_campaign(path)
    path.write_text(CAMPAIGN_FILE.replace('gauge_protocol = "throwaway"\n', ""))
    with pytest.raises(InputError, match=r"gauge_protocols.*got 'throwaway'"):
        read_campaign(path)
    hardware = ('machine = "machine.toml"\n[controller]\nprofile = "cia402"\nport = "h:502"\n'
                '[[gauges]]\ngauge = "y_x"\nprotocol = "throwaway"\nport = "/dev/ttyUSB0"\n')
    path.write_text(hardware)
    with pytest.raises(InputError, match=r"campaign\.toml:7: .*protocol must be one of .*, "
                                         r"got 'throwaway'"):
        read_campaign(path)
    with registered("throwaway", throwaway_gauge.BACKEND), \
            pytest.raises(InputError, match="no \\[\\[gauges\\]\\] entry for x_y"):
        read_campaign(path)  # the protocol taken: the file's next problem is said


def test_the_new_protocol_shows_the_simulators_faults(throwaway: str):
    """The engine's faults apply to a protocol it has never heard of."""
    with GaugeEndpoint(throwaway, lambda: -1.2345, transport="socket") as endpoint:
        gauge = open_indicator(throwaway, endpoint.port, unit="mm", where="tw")
        try:
            assert gauge.read().value_mm == -1.234  # 0.001 mm display, half to even
            endpoint.set_fault(Fault.ERROR, count=1)
            with pytest.raises(DeviceFault, match="tw: throwaway gauge error 07"):
                gauge.read()
            with pytest.raises(ValueError, match="no busy reply"):
                endpoint.set_fault(Fault.BUSY)
            endpoint.set_fault(Fault.INCH)
            reading = gauge.read()  # the frame says inch: converted
            assert (reading.unit, reading.frame) == ("inch", b"VAL=-0000.049;U=IN\n")
        finally:
            gauge.close()


def test_the_wizard_shows_the_new_protocols_hints(throwaway: str):
    out = io.StringIO()
    show_hints(Screen(Console(file=out, width=300)), throwaway)
    assert out.getvalue().splitlines() == [
        "The throwaway gauge answers READ.",
        f"The port of a {throwaway} gauge: a serial device (/dev/ttyUSB0) or "
        "socket://host:port; the line: 19200 8N1."]
