"""The wizard's gauge test opens a gauge as the campaign does: with its baud rate."""

from __future__ import annotations

import pytest

from ogacq_drivers.indicators import backend
from ogacq_drivers.sim.gauges import GaugeEndpoint
from ogacq.campaign import station
from ogacq.campaign.campaign_file import GaugeSpec
from ogacq.cli.wizard import connect


@pytest.mark.parametrize("baudrate", [None, 4800])
def test_the_wizard_reads_a_gauge_at_the_campaigns_baud_rate(monkeypatch, baudrate):
    opened = []

    def open_link(port, settings, *, where=""):
        link = real_open_link(port, settings, where=where)
        opened.append(link)
        return link

    real_open_link = station.open_link
    monkeypatch.setattr(station, "open_link", open_link)
    with GaugeEndpoint("mitutoyo-01a", lambda: 1.234, resolution_mm=0.001) as endpoint:
        spec = GaugeSpec("y_x", "mitutoyo-01a", endpoint.port, baudrate=baudrate)
        assert connect.test_read(spec, timeout_s=2.0) == 1.234
    default = backend("mitutoyo-01a").settings.baudrate
    assert [link.baudrate for link in opened] == [baudrate or default]
    assert default != 4800  # else the campaign's rate would not be seen
