"""Every thread the simulator, the gauge lines and a session writer start leaves Ctrl-C
to the main thread (drivers/threads.py), read from each thread's signal mask (SigBlk in
/proc/self/task/TID/status, Linux proc(5)). A SIGINT landed on one of them left the
wizard waiting at its question until a key was pressed: Python runs handlers in the
main thread, whose read() only the signal delivered to it interrupts (seen once at
load: tests/wizard/test_wizard_terminal.py's Ctrl-C at the first question unanswered
for 300 s, the ^C echoed)."""

from __future__ import annotations

import signal
import threading
from pathlib import Path

import pytest

from ogacq_drivers.indicators.concurrent import ConcurrentReader
from ogacq.model.machine import PAPER_PROTOTYPE_DIGITAL
from ogacq.model.parameters import vector
from ogacq.session.store import SessionWriter
from ogacq.sim.stack import SimulatorConfig, SimulatorStack
from ogacq.sim.truth import SimTruth

SIGINT_BIT = 1 << (signal.SIGINT - 1)  # SigBlk: a hex mask, signal n at bit n - 1


def blocks_sigint(native_id: int) -> bool:
    status = Path(f"/proc/self/task/{native_id}/status").read_text()
    blocked = next(line for line in status.splitlines() if line.startswith("SigBlk:"))
    return bool(int(blocked.split()[1], 16) & SIGINT_BIT)


def started_since(before: set[int | None]) -> list[threading.Thread]:
    return [t for t in threading.enumerate() if t.native_id not in before]


@pytest.mark.parametrize(("profile", "protocol"), [
    ("cia402", "mitutoyo-01a"),  # Modbus TCP, gauges on ptys
    ("iai-pcon", "usb-itn"),  # Modbus RTU over a pty bridge, USB cables on sockets
    ("cia402", "usb-itn-keyboard"),  # the keyboard cable's presses
])
def test_the_simulators_threads_leave_ctrl_c_to_the_main_thread(profile, protocol):
    before = {t.native_id for t in threading.enumerate()}
    config = SimulatorConfig(PAPER_PROTOTYPE_DIGITAL, SimTruth(vector()), profile=profile,
                             speed=50, gauge_protocol=protocol)
    with SimulatorStack(config):
        started = started_since(before)
        assert len(started) >= 2, [t.name for t in started]
        assert [t.name for t in started if not blocks_sigint(t.native_id)] == []
    assert not blocks_sigint(threading.get_native_id())  # the main thread takes it


def test_the_gauge_lines_workers_and_the_sessions_fsync_leave_ctrl_c(tmp_path):
    reader = ConcurrentReader({})
    try:
        on_workers = reader._map(lambda group: blocks_sigint(threading.get_native_id()),
                                 [["y_x"], ["z_x"], ["x_y"]])
    finally:
        reader.close()
    assert on_workers == [False, True, True]  # the caller reads the first line itself
    before = {t.native_id for t in threading.enumerate()}
    with SessionWriter.create(tmp_path / "s.jsonl", {"plan": None}):
        (syncer,) = started_since(before)
        assert blocks_sigint(syncer.native_id)
