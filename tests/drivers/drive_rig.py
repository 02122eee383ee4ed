"""One simulated drive on Modbus TCP and a controller client on it, for driver tests."""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager

from ogacq_drivers.axes.controller import AxisController
from ogacq_drivers.axes.modbus_link import ModbusLink
from ogacq_drivers.axes.profile import Profile
from ogacq_drivers.sim.clock import SimClock
from ogacq_drivers.sim.modbus_server import ModbusSimServer
from ogacq_drivers.sim.motion import MotionModel


@contextmanager
def simulated_drive(drive: Profile, client: Profile | None = None,
                    ) -> Iterator[tuple[AxisController, MotionModel, ModbusSimServer,
                                        ModbusLink]]:
    """A drive answering as ``drive``'s register map, and a controller that believes
    in ``client``'s (the same map unless a mismatch is the point of the test)."""
    model = MotionModel(SimClock(speed=50.0))
    server = ModbusSimServer(drive, model, transport="tcp")
    address = server.start()
    link = ModbusLink.for_profile(client or drive, transport="tcp", host=address.host,
                                  port=address.port)
    try:
        yield AxisController(client or drive, link), model, server, link
    finally:
        link.close()
        server.stop()
