"""Modbus Read Device Identification (function 43 / MEI 14, Modbus Application
Protocol V1.1b3 §6.21) through the client's link: the simulated controller says it
is "ogacq simulator", a plain pymodbus server answers its own (blank) objects, and
the modbus_tk drive emulator, which implements no function 43, is "not answered"."""

from __future__ import annotations

import asyncio
import threading
from collections.abc import Iterator
from contextlib import contextmanager

import pytest
from pymodbus.server import ModbusTcpServer
from pymodbus.simulator import DataType, SimData, SimDevice

from ogacq_drivers.axes.controller import AxisController
from ogacq_drivers.axes.identification import (
    SIMULATOR_VENDOR,
    describe,
    identify,
    simulated_by_identity,
)
from ogacq_drivers.axes.modbus_link import ModbusLink
from ogacq_drivers.axes.profile import load_profile
from ogacq_drivers.sim.clock import SimClock
from ogacq_drivers.sim.modbus_server import ModbusSimServer
from ogacq_drivers.sim.motion import MotionModel
from ogacq_drivers.sim.ptybridge import PtyBridge
from tests.emulators.drives import Cia402Drive, EmulatorServer

# modbus_tk 1.1.5 calls threading.Event.isSet(), deprecated since Python 3.10
pytestmark = pytest.mark.filterwarnings("ignore:isSet:DeprecationWarning")


@pytest.mark.parametrize(("name", "transport"), [("cia402", "tcp"), ("iai-pcon", "rtu")])
def test_the_simulated_controller_says_it_is_the_simulator(name: str, transport: str) -> None:
    profile = load_profile(name)
    server = ModbusSimServer(profile, MotionModel(SimClock(speed=50.0)),
                             transport=transport)  # type: ignore[arg-type]
    address = server.start()
    link = (ModbusLink.for_profile(profile, transport="tcp", port=int(address.port))
            if transport == "tcp" else
            ModbusLink.for_profile(profile, transport="rtu", serial_port=str(address.port),
                                   timeout_s=1.0))
    try:
        said = identify(AxisController(profile, link))
    finally:
        link.close()
        server.stop()
    assert set(said) == set(profile.device_ids)
    assert all(v == {"vendor": SIMULATOR_VENDOR, "product": name, "revision": "1.0"}
               for v in said.values())
    assert simulated_by_identity(said)
    assert describe(said) == f"x, y, z: ogacq simulator {name} 1.0"


@contextmanager
def plain_pymodbus_server() -> Iterator[int]:
    """A pymodbus server with no identity given: it answers 43/14 with empty objects."""
    ready, port = threading.Event(), []
    stop: list[asyncio.Event] = []

    async def serve() -> None:
        device = SimDevice(1, simdata=([SimData(0, values=False, datatype=DataType.BITS)],
                                       [SimData(0, values=False, datatype=DataType.BITS)],
                                       [SimData(0, values=0, datatype=DataType.REGISTERS)],
                                       [SimData(0, values=0, datatype=DataType.REGISTERS)]))
        server = ModbusTcpServer([device], address=("127.0.0.1", 0))
        await server.serve_forever(background=True)
        port.append(server.transport.sockets[0].getsockname()[1])  # type: ignore[union-attr]
        stop.append(asyncio.Event())
        ready.set()
        await stop[0].wait()
        await server.shutdown()

    loop = asyncio.new_event_loop()
    thread = threading.Thread(target=loop.run_until_complete, args=(serve(),), daemon=True)
    thread.start()
    assert ready.wait(10)
    try:
        yield port[0]
    finally:
        loop.call_soon_threadsafe(stop[0].set)
        thread.join(10)


def test_a_drive_without_a_vendor_is_answered_and_not_the_simulator() -> None:
    with plain_pymodbus_server() as port:
        link = ModbusLink(transport="tcp", port=port, timeout_s=1.0)
        try:
            objects = link.read_identification(1)
        finally:
            link.close()
    assert objects == {}  # pymodbus holds no identity unless given one
    assert not simulated_by_identity({"x": {"vendor": "", "product": "", "revision": ""}})


@pytest.mark.parametrize("transport", ["tcp", "rtu"])
def test_a_drive_without_function_43_is_not_answered(transport: str) -> None:
    profile = load_profile("cia402")
    bridge = PtyBridge(baudrate=None).start() if transport == "rtu" else None
    server = EmulatorServer(transport, serial_path=bridge.server_path if bridge else "",
                            baudrate=profile.transport.baudrate)
    for unit in profile.device_ids.values():
        server.add(unit, Cia402Drive)
    port = server.start()
    link = (ModbusLink.for_profile(profile, transport="tcp", port=port) if bridge is None else
            ModbusLink.for_profile(profile, transport="rtu", serial_port=bridge.client_path,
                                   timeout_s=0.5))
    try:
        said = identify(AxisController(profile, link))
        failures = link.stats.failures
    finally:
        link.close()
        server.stop()
        if bridge is not None:
            bridge.stop()
    assert said == dict.fromkeys(profile.device_ids)
    assert not simulated_by_identity(said)
    assert failures == 0  # optional objects: not a fault of the link
    assert describe(said) == "x, y, z: not answered (no function 43/14)"
