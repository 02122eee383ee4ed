"""A station on the independent drive emulator (modbus_tk, tests/emulators/drives.py),
not on ogacq's simulator: three CiA 402 drives behind a TCP proxy that can cut
the line, and six 01A gauges on pseudo-terminals that read the machine where the
emulated drives physically put it (from each drive's home switch, whatever its
counter says). The gauges' physics is the exact measurement model with a hidden
truth (ogacq.sim.machine): the drives, what this rig tests ogacq against, share
nothing with ogacq's code.
"""

from __future__ import annotations

import contextlib
import threading
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

from ogacq_drivers.sim.clock import SimClock
from ogacq.model.gauges import GAUGE_KEYS, Gauge
from ogacq.model.machine import MachineSpec
from ogacq.session.store import load_session
from ogacq.sim.machine import SimMachine
from ogacq.sim.stack import make_gauge
from ogacq.sim.truth import random_truth
from tests.campaign.tcp_proxy import FaultyProxy
from tests.emulators.drives import Cia402Drive, EmulatorServer

COUNTS_PER_MM = 100.0  # the emulated drives' electronic gear (as the cia402 profile says)
UNITS = {"x": 1, "y": 2, "z": 3}  # the cia402 profile's device ids
MACHINE = """leg_length_mm = 310.25
rho_min_mm = -10.0
rho_max_mm = 10.0
gauge_resolution_mm = 0.001
"""
NOISE_MM = 0.0003


class _Encoders:
    """The emulated axes as the gauges' physics sees them: physical position in mm
    from each home switch, the side each last moved from."""

    def __init__(self, drives: dict[str, Cia402Drive]) -> None:
        self.drives = drives

    def raw_position_mm(self, axis: str) -> float:
        with self.drives[axis].lock:
            return self.drives[axis].physical_counts() / COUNTS_PER_MM

    def last_direction(self, axis: str) -> int:
        return self.drives[axis].motion.direction or 1

    def stopped_at_s(self) -> float | None:
        return None  # no ringing: the gauges are at rest once the drives are


@dataclass
class EmulatedStation:
    drives: dict[str, Cia402Drive]
    proxy: FaultyProxy
    ports: dict[str, str]  # gauge key -> pty

    def campaign(self, folder: Path, name: str, *, rehome: bool = True) -> Path:
        folder.mkdir(parents=True, exist_ok=True)
        (folder / "machine.toml").write_text(MACHINE)
        gauges = "".join(f'\n[[gauges]]\ngauge = "{k}"\nprotocol = "mitutoyo-01a"\n'
                         f'port = "{p}"\n' for k, p in self.ports.items())
        path = folder / f"{name}.toml"
        path.write_text(
            f'machine = "machine.toml"\nsession = "{name}.jsonl"\n\n[controller]\n'
            f'profile = "cia402"\nport = "127.0.0.1:{self.proxy.port}"\n'
            f"reconnect_attempts = 6\nreconnect_backoff_s = 0.2\n"
            f"rehome_after_loss = {'true' if rehome else 'false'}\n\n"
            '[protocol]\ncycles = 1\nsettle = "fixed"\nsettle_s = 0.02\n\n'
            "[stability]\nreadings = 2\ntolerance_mm = 0.002\ntimeout_s = 2.0\n" + gauges)
        return path

    def requests(self) -> dict[str, int]:
        return {a: len(d.requests) for a, d in self.drives.items()}

    def power_cycle_when(self, session: Path, readings: int, *, off_s: float = 1.0,
                         counters: dict[str, int] | None = None) -> threading.Thread:
        """Once ``readings`` readings are on file: the line cut (the drives' Ethernet
        goes with their power), every drive switched off and on with its counter
        restarted at ``counters``, the line back after ``off_s``."""
        counters = counters or {"x": 6777, "y": 8554, "z": -2331}  # beyond the soft limits

        def watch() -> None:
            deadline = time.monotonic() + 120
            while time.monotonic() < deadline:
                with contextlib.suppress(Exception):
                    if session.exists() and len(load_session(session).readings) >= readings:
                        break
                time.sleep(0.05)
            self.proxy.stay_down = True
            self.proxy.cut()
            for drive in self.drives.values():
                # A write forwarded just before the cut may reach the server only now:
                # it was sent to the drive before the power loss, and must not count
                # as a set-point after it (the race of a CI run: "y: 1 == 0").
                drive.power_off()
            time.sleep(off_s)
            for axis, drive in self.drives.items():
                drive.power_cycle(counters[axis])
            self.proxy.come_back()

        thread = threading.Thread(target=watch, daemon=True, name="power cycle")
        thread.start()
        return thread


def target_writes(drive: Cia402Drive, start: int = 0, end: int | None = None) -> int:
    """Writes to the target position 607Ah among requests [start, end)."""
    return sum(1 for pdu in drive.requests[start:end]
               if pdu[0] in (6, 16) and int.from_bytes(pdu[1:3], "big") == 0x607A)


def event_index(drive: Cia402Drive, what: str, after: int = 0) -> int | None:
    """The request count at the first event ``what`` at or after request ``after``."""
    return next((at for at, event in drive.events if event == what and at >= after), None)


@contextlib.contextmanager
def emulated_station(seed: int = 5) -> Iterator[EmulatedStation]:
    server = EmulatorServer("tcp")
    drives = {a: server.add(u, Cia402Drive) for a, u in UNITS.items()}
    port = server.start()
    assert port is not None
    truth = random_truth(seed, noise_mm=NOISE_MM)
    spec = MachineSpec(310.25, -10.0, 10.0, gauge_resolution_mm=0.001)
    machine = SimMachine(spec, truth, _Encoders(drives), SimClock(1.0), seed=seed)
    gauges = {key: make_gauge("mitutoyo-01a",
                              machine.value_source(*Gauge.parse(key).indices),
                              resolution_mm=0.001, transport="pty", name=f"gauge {key}")
              for key in GAUGE_KEYS}
    proxy = FaultyProxy(("127.0.0.1", port)).start()
    try:
        for endpoint in gauges.values():
            endpoint.start()
        yield EmulatedStation(drives, proxy, {k: g.port for k, g in gauges.items()})
    finally:
        for endpoint in gauges.values():
            endpoint.close()
        proxy.close()
        server.stop()

