"""Benchmark: the campaign's own overhead per reading (prints figures; not a test).

A simulated papers' campaign (72 readings) is run through the real drivers. From
its wall time we subtract what the machine and the wire take by themselves:
the simulated motion (trapezoidal moves plus settling, at the simulator's
speed-up), the protocol's settle time, and the gauges' line time (each request
and reply at 9600 baud). What remains, per reading, is the campaign's own
overhead: runner, session writes (fsync), Modbus polling, parsing.
Target: under 5 ms per reading on top of the wire time.

Run: python bench/bench_campaign.py
"""

from __future__ import annotations

import math
import tempfile
import time
from pathlib import Path

from ogacq.campaign_file import read_campaign
from ogacq.protocol.plan import Move, campaign_steps
from ogacq.protocol.runner import CampaignRunner
from ogacq.session.store import SessionWriter
from ogacq.station import open_station

MACHINE = "leg_length_mm = 310.25\nrho_min_mm = -100.0\nrho_max_mm = 60.0\n" \
          "gauge_resolution_mm = 0.001\n"


def move_time_s(distance_mm: float, speed: float, accel: float) -> float:
    if distance_mm <= speed**2 / accel:
        return 2 * math.sqrt(distance_mm / accel) if distance_mm > 0 else 0.0
    return distance_mm / speed + speed / accel


def main() -> None:
    folder = Path(tempfile.mkdtemp(prefix="ogacq-bench-"))
    (folder / "machine.toml").write_text(MACHINE)
    (folder / "campaign.toml").write_text(
        'machine = "machine.toml"\nsession = "s.jsonl"\n[simulator]\nseed = 1\nspeed = 25\n'
        '[protocol]\nsettle_s = 1.0\n')
    campaign = read_campaign(folder / "campaign.toml")
    with open_station(campaign) as station:
        station.prepare()
        motion = station.simulator.motion
        speed_up = station.simulator.clock.speed
        with SessionWriter.create(campaign.session, {"plan": None}) as writer:
            runner = CampaignRunner(station, writer, campaign.protocol, campaign.machine)
            start = time.perf_counter()
            runner.run()
            wall = time.perf_counter() - start
        gauges = station.simulator.gauges.values()
        exchanges = sum(g.requests_received for g in gauges)
        line_s = sum(g.requests_received * 2 + g.frames_sent * 13 for g in gauges) \
            * next(iter(gauges)).byte_time_s

    motion_sim = 0.0
    last = (0.0, 0.0, 0.0)
    for step in campaign_steps(campaign.protocol, campaign.machine):
        if isinstance(step, Move):
            longest = max(abs(a - b) for a, b in zip(step.q_mm, last, strict=True))
            motion_sim += move_time_s(longest, motion.speed_mm_s, motion.accel_mm_s2)
            motion_sim += motion.settle_s
            last = step.q_mm
    motion_s = motion_sim / speed_up
    reads = 36
    settle_s = reads * campaign.protocol.settle_s / speed_up
    readings = runner.total_readings
    overhead = wall - motion_s - settle_s - line_s
    print(f"campaign: {readings} readings in {wall:.2f} s wall (simulator x{speed_up:g})")
    print(f"  motion {motion_s:.2f} s + settle {settle_s:.2f} s + gauge line {line_s:.2f} s "
          f"({exchanges} exchanges at 9600 baud)")
    print(f"  overhead {overhead:.2f} s = {overhead / readings * 1000:.2f} ms per reading "
          f"(target < 5 ms); wire time per reading {line_s / readings * 1000:.1f} ms, "
          f"overhead/wire ratio {overhead / line_s:.2f}")


if __name__ == "__main__":
    main()
