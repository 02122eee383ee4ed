"""Faults in the middle of a campaign: retried within bounds, else a safe, resumable stop."""

import pytest

from ogacq_drivers.axes.reconnect import ReconnectPolicy
from ogacq_drivers.sim.gauges import Fault
from ogacq.campaign.campaign_file import read_campaign
from ogacq.campaign.station import open_station
from ogacq.protocol.runner import CampaignRunner, CampaignStopped, Progress
from ogacq.session.records import EndRecord, FaultRecord
from ogacq.session.store import SessionWriter, load_session
from tests.campaign.conftest import write_campaign

FAST = "\n[stability]\nreadings = 2\ntolerance_mm = 0.003\ntimeout_s = 1.0\n"


def runner_for(station, writer, campaign, recorded=(), observer=None):
    return CampaignRunner(station, writer, campaign.protocol, campaign.machine,
                          recorded=set(recorded), observer=observer)


def inject_at(station, reading: int, gauge: str, kind: Fault, **kw):
    fired = []

    def observer(progress: Progress) -> None:
        if progress.done == reading and not fired:
            station.simulator.gauges[gauge].set_fault(kind, **kw)
            fired.append(True)

    return observer


def test_transient_911_is_retried_and_the_campaign_completes(campaign_dir):
    campaign = read_campaign(write_campaign(campaign_dir, seed=2, extra=FAST))
    with open_station(campaign) as station:
        station.prepare()
        with SessionWriter.create(campaign.session, {"plan": None}) as writer:
            observer = inject_at(station, 10, "z_x", Fault.ERROR, code="911", count=2)
            runner_for(station, writer, campaign, observer=observer).run()
    session = load_session(campaign.session)
    assert session.finished and len(session.readings) == 72
    faults = session.of_type(FaultRecord)
    assert faults and all(f.gauge == "z_x" for f in faults)
    assert any("911" in f.message for f in faults)


@pytest.mark.parametrize("kind", [Fault.SILENCE, Fault.UNPLUG])
def test_dead_gauge_stops_safely_names_it_and_resumes(campaign_dir, kind):
    campaign = read_campaign(write_campaign(campaign_dir, seed=6, extra=FAST))
    with open_station(campaign) as station:
        station.prepare()
        writer = SessionWriter.create(campaign.session, {"plan": None})
        observer = inject_at(station, 30, "z_y", kind)
        with pytest.raises(CampaignStopped) as stopped:
            runner_for(station, writer, campaign, observer=observer).run()
        writer.close()
        assert "z_y" in stopped.value.reason
        session = load_session(campaign.session)
        end = session.of_type(EndRecord)[-1]
        assert end.status == "stopped" and "z_y" in end.reason
        assert end.axes_stopped is True
        faults = session.of_type(FaultRecord)
        assert len(faults) == 3  # bounded: three attempts, then stop
        failed_step = faults[0].step
        # everything up to the fault is on file; nothing from the dead gauge since
        assert 30 <= len(session.readings) <= 31
        assert (failed_step, "z_y") not in session.recorded()

        if kind is Fault.UNPLUG:
            return  # a real unplugged gauge needs a person: the stop is what matters here
        station.simulator.gauges["z_y"].clear_fault()
        with SessionWriter.reopen(session) as writer:
            runner_for(station, writer, campaign, recorded=session.recorded()).run()
    session = load_session(campaign.session)
    keys = [(r.step, r.gauge.key) for r in session.readings]
    assert len(keys) == len(set(keys)) == 72
    assert session.finished


def test_axis_alarm_is_reset_and_the_move_retried(campaign_dir):
    campaign = read_campaign(write_campaign(campaign_dir, seed=7, extra=FAST))
    with open_station(campaign) as station:
        station.prepare()
        fired = []

        def observer(progress: Progress) -> None:
            if progress.done == 20 and not fired:
                station.simulator.motion.inject_alarm("y")
                fired.append(True)

        with SessionWriter.create(campaign.session, {"plan": None}) as writer:
            runner_for(station, writer, campaign, observer=observer).run()
    session = load_session(campaign.session)
    assert session.finished and len(session.readings) == 72
    faults = [f for f in session.of_type(FaultRecord) if f.during == "move"]
    assert len(faults) == 1 and "alarm" in faults[0].message


def test_controller_that_stops_answering_stops_the_campaign_safely(campaign_dir):
    campaign = read_campaign(write_campaign(campaign_dir, seed=8, extra=FAST))
    with open_station(campaign) as station:
        station.prepare()
        # a long outage: the bounded reconnect (short here) gives up, then the stop
        station.reconnect = ReconnectPolicy(attempts=2, backoff_s=0.05)
        fired = []

        def observer(progress: Progress) -> None:
            if progress.done == 12 and not fired:
                station.simulator.server.stop()  # the Modbus side goes silent
                fired.append(True)

        writer = SessionWriter.create(campaign.session, {"plan": None})
        with pytest.raises(CampaignStopped) as stopped:
            runner_for(station, writer, campaign, observer=observer).run()
        writer.close()
    assert "modbus" in stopped.value.reason.lower()
    session = load_session(campaign.session)
    end = session.of_type(EndRecord)[-1]
    assert end.status == "stopped"
    assert end.axes_stopped is False  # and the session says the stop could not be sent
    assert len(session.readings) == 12  # nothing measured is lost


@pytest.mark.parametrize("kind", [Fault.SILENCE, Fault.UNPLUG])
@pytest.mark.parametrize("protocol", ["usb-itn", "usb-itn-keyboard"])
def test_dead_usb_itn_gauge_stops_safely_names_it_and_resumes(campaign_dir, kind, protocol):
    """A USB-ITN cable (data mode through pyusb, or keyboard mode) silent or pulled
    out mid-campaign: named in one line, axes stopped, nothing lost, and it resumes."""
    extra = FAST + f'[simulator.gauge_protocols]\nz_y = "{protocol}"\n'
    path = write_campaign(campaign_dir, seed=6, extra="")
    path.write_text(path.read_text().replace("[protocol]", extra + "\n[protocol]", 1))
    campaign = read_campaign(path)
    with open_station(campaign) as station:
        port = station.description["gauges"]["z_y"]["port"]
        assert port.startswith("usbsim://") if protocol == "usb-itn" else "/dev/input/" in port
        station.prepare()
        writer = SessionWriter.create(campaign.session, {"plan": None})
        observer = inject_at(station, 30, "z_y", kind)
        with pytest.raises(CampaignStopped) as stopped:
            runner_for(station, writer, campaign, observer=observer).run()
        writer.close()
        assert "z_y" in stopped.value.reason and "\n" not in stopped.value.reason
        session = load_session(campaign.session)
        end = session.of_type(EndRecord)[-1]
        assert end.status == "stopped" and end.axes_stopped is True
        assert 30 <= len(session.readings) <= 31
        if kind is Fault.UNPLUG:
            assert "unplugged" in end.reason
            return
        assert "no reply" in end.reason or "no value typed" in end.reason
        station.simulator.gauges["z_y"].clear_fault()
        with SessionWriter.reopen(session) as writer:
            runner_for(station, writer, campaign, recorded=session.recorded()).run()
    session = load_session(campaign.session)
    keys = [(r.step, r.gauge.key) for r in session.readings]
    assert len(keys) == len(set(keys)) == 72 and session.finished
