"""Benchmark: the campaign's own overhead per reading (prints figures; not a test).

A papers' campaign (72 readings) runs through the real drivers against
`ogacq sim` in a separate process, as it would against a real controller and
real gauges (an in-process simulator would bill its own physics to the
campaign). From the campaign's wall time we subtract what the machine and the
wire take by themselves: the simulated motion (trapezoidal moves plus
settling, at the simulator's speed-up), the protocol's settle time, and the
gauges' line time (each request and reply at 9600 baud). What remains, per
reading, is the campaign's own overhead: runner, session writes (fsync),
Modbus transactions of verified moves and status polls, frame parsing.
Target: under 5 ms per reading on top of the wire time.

The overhead so defined still holds the simulated devices' own response time:
a simulated gauge answers a fraction of a millisecond after the request (a real
one after its own delay). The benchmark measures that with a plain client (raw
pty, no ogacq code) and prints what is left beside the total. The simulated
drive's response is left in: its transactions overlap the motion, except those
that start and confirm a move, and the split is not measured here.

Run: python bench/bench_campaign.py
"""

from __future__ import annotations

import json
import math
import os
import select
import signal
import statistics
import subprocess
import sys
import tempfile
import time
import tty
from pathlib import Path

from ogacq_drivers.indicators.mitutoyo_01a import encode_request
from ogacq.campaign_file import read_campaign
from ogacq.protocol.plan import Move, campaign_steps
from ogacq.protocol.runner import CampaignRunner
from ogacq.session.records import MoveRecord
from ogacq.session.store import SessionWriter
from ogacq.station import open_station

SPEED = 25.0
SETTLE_S = 1.0  # machine time
BAUD_BYTE_S = 10 / 9600
# the simulator's motion model defaults (drivers/sim/motion.py)
SPEED_MM_S, ACCEL_MM_S2, MOTION_SETTLE_S = 100.0, 2000.0, 0.02
MACHINE = "leg_length_mm = 310.25\nrho_min_mm = -100.0\nrho_max_mm = 60.0\n" \
          "gauge_resolution_mm = 0.01\n"


def move_time_s(distance_mm: float) -> float:
    if distance_mm <= 0:
        return 0.0
    if distance_mm <= SPEED_MM_S**2 / ACCEL_MM_S2:
        return 2 * math.sqrt(distance_mm / ACCEL_MM_S2)
    return distance_mm / SPEED_MM_S + SPEED_MM_S / ACCEL_MM_S2


def start_simulator() -> tuple[subprocess.Popen, dict]:
    proc = subprocess.Popen([sys.executable, "-m", "ogacq", "sim", "--speed", str(SPEED),
                             "--seed", "1", "--json"], stdout=subprocess.PIPE,
                            start_new_session=True, text=True)
    return proc, json.loads(proc.stdout.readline())


def _count_exchanges(indicators: dict) -> list[int]:
    """Count request/reply exchanges as the campaign makes them (a stable reading
    takes three or more, as many as it needs to agree)."""
    counter = [0]
    for indicator in indicators.values():
        read = indicator.read

        def counted(*args, _read=read, **kwargs):
            counter[0] += 1
            return _read(*args, **kwargs)

        indicator.read = counted
    return counter


def gauge_response_s(port: str, request: bytes, n: int = 60) -> float:
    """Median wait of a plain client for a simulated gauge's reply, beyond line time."""
    fd = os.open(port, os.O_RDWR | os.O_NOCTTY)
    try:
        tty.setraw(fd)
        waits = []
        for _ in range(n):
            start = time.perf_counter()
            os.write(fd, request)
            reply = b""
            while not reply.endswith(b"\r"):
                select.select([fd], [], [], 1.0)
                reply += os.read(fd, 64)
            waits.append(time.perf_counter() - start - (len(request) + len(reply)) * BAUD_BYTE_S)
        return statistics.median(waits)
    finally:
        os.close(fd)


def campaign_text(info: dict) -> str:
    m = info["modbus"]
    lines = ['machine = "machine.toml"', 'session = "s.jsonl"', "[controller]",
             f'profile = "{m["profile"]}"', f'port = "{m["host"]}:{m["port"]}"',
             # the external simulator settles on its own clock: real seconds here
             "[protocol]", f"settle_s = {SETTLE_S / SPEED}"]
    for key, g in info["gauges"].items():
        lines += ["[[gauges]]", f'gauge = "{key}"', f'protocol = "{g["protocol"]}"',
                  f'port = "{g["port"]}"']
    return "\n".join(lines) + "\n"


def main() -> None:
    folder = Path(tempfile.mkdtemp(prefix="ogacq-bench-"))
    (folder / "machine.toml").write_text(MACHINE)
    proc, info = start_simulator()
    try:
        (folder / "campaign.toml").write_text(campaign_text(info))
        campaign = read_campaign(folder / "campaign.toml")
        with open_station(campaign) as station:
            station.prepare()
            exchanges = _count_exchanges(station.indicators)
            with SessionWriter.create(campaign.session, {"plan": None}) as writer:
                runner = CampaignRunner(station, writer, campaign.protocol, campaign.machine)
                start = time.perf_counter()
                runner.run()
                wall = time.perf_counter() - start
        from ogacq.session.store import load_session

        moves = load_session(campaign.session).of_type(MoveRecord)
        gauge = info["gauges"]["y_x"]
        gauge_s = gauge_response_s(gauge["port"], encode_request())
    finally:
        os.killpg(proc.pid, signal.SIGINT)
        proc.wait(10)

    motion_sim, last = 0.0, (0.0, 0.0, 0.0)
    for move in moves:
        motion_sim += move_time_s(max(abs(a - b) for a, b in
                                      zip(move.q_mm, last, strict=True))) + MOTION_SETTLE_S
        last = tuple(move.q_mm)
    motion_s = motion_sim / SPEED
    reads = sum(1 for s in campaign_steps(campaign.protocol, campaign.machine)
                if not isinstance(s, Move)) - 3
    settle_s = reads * campaign.protocol.settle_s
    readings = runner.total_readings
    # every request/reply exchange is 2 + 13 bytes on the line
    line_s = exchanges[0] * 15 * BAUD_BYTE_S
    overhead = wall - motion_s - settle_s - line_s
    print(f"campaign: {readings} readings, {len(moves)} moves in {wall:.2f} s wall "
          f"(ogacq sim in its own process, x{SPEED:g})")
    print(f"  motion {motion_s:.2f} s + settle {settle_s:.2f} s + gauge line {line_s:.2f} s "
          f"({exchanges[0]} exchanges at 9600 baud)")
    print(f"  overhead {overhead:.2f} s = {overhead / readings * 1000:.2f} ms per reading "
          f"(target < 5 ms); wire time per reading {line_s / readings * 1000:.1f} ms, "
          f"overhead/wire ratio {overhead / line_s:.2f}")
    gauges = exchanges[0] * gauge_s
    print(f"  of which the simulated gauges' own response (plain client): "
          f"{gauge_s * 1000:.2f} ms x {exchanges[0]} exchanges = "
          f"{gauges / readings * 1000:.2f} ms per reading; the rest, "
          f"{(overhead - gauges) / readings * 1000:.2f} ms per reading, is ogacq's "
          "and the simulated drive's")


if __name__ == "__main__":
    main()
