"""The network between the tool and the controller, as a shop floor treats it: a
connection reset once is ridden out (bounded reconnect, axes stopped and re-read,
every reading exactly once); an outage that lasts stops safely, in one line with
exit 3, and resumes; a controller answering every request slowly meets the
campaign's deadline. Real parts: ``ogacq sim`` in its own process, the real
drivers, and a TCP proxy between them that misbehaves on cue."""

from __future__ import annotations

import pytest

from ogacq.campaign.campaign_file import read_campaign
from ogacq.protocol.deadline import default_deadline_s
from ogacq.session.records import EndRecord, FaultRecord, ReconnectRecord
from ogacq.session.store import load_session
from tests.campaign.tcp_proxy import FaultyProxy
from tests.writeback.conftest import FAST_STABILITY, ogacq_here, sim_campaign, simulator

# The reset lands mid-campaign: homing and the first moves take about 150 requests,
# the 24 readings of one cycle about 420 in all.
MID_CAMPAIGN = 300


@pytest.fixture(scope="module")
def served(tmp_path_factory):
    folder = tmp_path_factory.mktemp("network")
    with simulator(folder, "cia402", seed=4) as info:
        yield folder, info


def campaign_through(proxy: FaultyProxy, served, name: str, top: str = "") -> str:
    folder, info = served
    m = info["modbus"]
    path = sim_campaign(folder, info, name=name, extra="cycles = 1\n" + FAST_STABILITY)
    text = path.read_text().replace(
        f'port = "{m["host"]}:{m["port"]}"',
        f'port = "127.0.0.1:{proxy.port}"\nreconnect_attempts = 3\nreconnect_backoff_s = 0.05')
    path.write_text(top + text)
    return str(path)


def upstream(served) -> tuple[str, int]:
    m = served[1]["modbus"]
    return m["host"], m["port"]


def unique_readings(session) -> int:
    keys = [(r.step, r.gauge) for r in session.readings]
    assert len(keys) == len(set(keys)), "a reading was taken twice"
    return len(keys)


def test_a_connection_reset_mid_campaign_is_ridden_out(served, capsys, monkeypatch):
    with FaultyProxy(upstream(served), reset_at=MID_CAMPAIGN) as proxy:
        path = campaign_through(proxy, served, "reset-once")
        ran = ogacq_here(capsys, monkeypatch, "run", path, "--json")
    assert ran.returncode == 0, ran.stderr
    assert proxy.resets == 1
    session = load_session(read_campaign(path).session)
    assert session.finished and unique_readings(session) == 24
    fault = session.of_type(FaultRecord)
    assert len(fault) == 1 and fault[0].error == "LinkError"
    (back,) = session.of_type(ReconnectRecord)
    assert back.connected and back.axes_stopped and set(back.positions_mm) == set("xyz")
    assert back.alarms == dict.fromkeys("xyz", 0)
    assert session.header.station["controller"]["reconnect"] == {"attempts": 3,
                                                                   "backoff_s": 0.05}


def test_an_outage_that_lasts_stops_safely_in_one_line_and_resumes(served, capsys,
                                                                   monkeypatch):
    with FaultyProxy(upstream(served), reset_at=MID_CAMPAIGN, stay_down=True) as proxy:
        path = campaign_through(proxy, served, "outage")
        ran = ogacq_here(capsys, monkeypatch, "run", path)
        assert ran.returncode == 3
        stopped = [line for line in ran.stderr.splitlines() if "campaign stopped" in line]
        assert len(stopped) == 1 and "Traceback" not in ran.stderr
        session = load_session(read_campaign(path).session)
        (gave_up,) = session.of_type(ReconnectRecord)
        assert not gave_up.connected and "3 reconnect attempt(s)" in gave_up.message
        end = session.of_type(EndRecord)[-1]
        assert end.status == "stopped" and end.axes_stopped is False  # unreachable
        taken = unique_readings(session)
        assert 0 < taken < 24

        proxy.come_back()
        resumed = ogacq_here(capsys, monkeypatch, "resume", str(session.path), "--json")
    assert resumed.returncode == 0, resumed.stderr
    session = load_session(session.path)
    assert session.finished and unique_readings(session) == 24


def test_a_controller_answering_slowly_meets_the_deadline(served, capsys, monkeypatch):
    """Every answer held back 10 ms: each step stays within its own timeout, so only
    the campaign's deadline stops it; it is recorded, and the session resumes."""
    with FaultyProxy(upstream(served), delay_s=0.01) as proxy:
        path = campaign_through(proxy, served, "slow", top="deadline_s = 1\n")
        ran = ogacq_here(capsys, monkeypatch, "run", path)
    assert ran.returncode == 3
    assert "deadline" in ran.stderr and "Traceback" not in ran.stderr
    session = load_session(read_campaign(path).session)
    assert session.header.station["deadline_s"] == 1
    end = session.of_type(EndRecord)[-1]
    assert end.status == "stopped" and "deadline" in end.reason and end.axes_stopped
    assert unique_readings(session) < 24


def test_the_default_deadline_is_every_step_at_its_timeout(served):
    campaign = read_campaign(sim_campaign(served[0], served[1], name="plan"))
    plan, machine = campaign.protocol, campaign.machine
    # the paper's protocol: 3 legs x 3 cycles x 4 postures = 36 reading steps, 39 moves
    assert default_deadline_s(plan, machine) == pytest.approx(
        39 * plan.move_timeout_s + 36 * (plan.settle_s + 2 * plan.stability.timeout_s))
    assert campaign.deadline_s is None
