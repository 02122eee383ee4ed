#!/usr/bin/env python3
"""Benchmark (not a test): round trip of a three-axis status poll, beside the frames' wire time.

    python bench/bench_status_poll.py [--polls 200]

For each profile (iai-pcon, cia402) and transport (Modbus TCP on 127.0.0.1, Modbus
RTU at 38400 baud over a pseudo-terminal), it times ``AxisController.read_status()``
for the three axes against the simulated controller, and prints it beside the
time the frames need on the wire:

- RTU: bytes x bits per byte / baud, where the bytes are the request and response
  frames of every read of the poll (checked against the bytes the pty bridge
  relayed). The **pty bridge** paces the bytes at the baud rate, in both
  directions; the pymodbus server and client write as fast as they can, so the
  extra time over the wire time is software: client polling, server, thread
  switches. Modbus RTU also asks for 3.5 character times of silence between
  frames; that figure is printed separately (``+t3.5``).
- TCP: the frames' own size (MBAP header + PDU) is noted; on loopback there is
  no wire, so the ratio given is to the time those bytes plus TCP/IP/Ethernet
  headers (54 bytes per frame) would take on 100 Mbit/s Ethernet, for scale only.
"""

from __future__ import annotations

import argparse
import logging
import statistics
import time
from dataclasses import dataclass

from ogacq_drivers.axes.controller import AxisController
from ogacq_drivers.axes.modbus_link import ModbusLink
from ogacq_drivers.axes.profile import load_profile
from ogacq_drivers.sim.clock import SimClock
from ogacq_drivers.sim.modbus_server import ModbusSimServer
from ogacq_drivers.sim.motion import MotionModel

ETHERNET_BIT_S = 1 / 100e6
TCP_IP_ETHERNET_OVERHEAD_BYTES = 54  # Ethernet 14 + IPv4 20 + TCP 20, no options


@dataclass(frozen=True)
class PollFrames:
    transactions: int
    request_bytes: int
    response_bytes: int

    @property
    def total_bytes(self) -> int:
        return self.request_bytes + self.response_bytes


def frames_per_poll(controller: AxisController, transport: str) -> PollFrames:
    """Bytes of every FC3 request/response pair a three-axis status poll makes."""
    request = response = 0
    reads = controller.status_reads
    for _, count in reads:
        if transport == "rtu":  # id, fc, address, count, crc / id, fc, byte count, data, crc
            request += 8
            response += 5 + 2 * count
        else:  # MBAP (7) + fc, address, count / MBAP + fc, byte count, data
            request += 12
            response += 9 + 2 * count
    axes = len(controller.axes)
    return PollFrames(len(reads) * axes, request * axes, response * axes)


def bench(profile_name: str, transport: str, polls: int) -> str:
    profile = load_profile(profile_name)
    model = MotionModel(SimClock(speed=1.0))
    with ModbusSimServer(profile, model, transport=transport) as server:  # type: ignore[arg-type]
        address = server.address
        if transport == "tcp":
            link = ModbusLink.for_profile(profile, transport="tcp", port=int(address.port))
        else:
            link = ModbusLink.for_profile(profile, transport="rtu", serial_port=str(address.port))
        with link:
            controller = AxisController(profile, link)
            for _ in range(5):  # warm up: connect, first frames
                controller.read_status()
            bridge = server.bridge
            before = dict(bridge.counters) if bridge else {}
            times = []
            for _ in range(polls):
                started = time.perf_counter()
                controller.read_status()
                times.append(time.perf_counter() - started)
            after = dict(bridge.counters) if bridge else {}
    frames = frames_per_poll(controller, transport)
    median = statistics.median(times)
    p95 = sorted(times)[int(0.95 * (len(times) - 1))]
    label = f"{profile_name:8s} {transport.upper():3s}"
    head = (
        f"{label}  {frames.transactions} reads, {frames.total_bytes:3d} B/poll   "
        f"median {median * 1e3:7.3f} ms  p95 {p95 * 1e3:7.3f} ms"
    )
    if transport == "rtu":
        bits = profile.transport.bits_per_byte
        baud = profile.transport.baudrate
        wire = frames.total_bytes * bits / baud
        silence = frames.transactions * 2 * 3.5 * bits / baud
        relayed = sum(after[k][0] - before[k][0] for k in after) / polls
        return (
            f"{head}   wire {wire * 1e3:6.3f} ms (+t3.5 {silence * 1e3:5.3f} ms)  "
            f"ratio {median / wire:5.2f} ({median / (wire + silence):4.2f} with t3.5)  "
            f"[bridge relayed {relayed:.0f} B/poll]"
        )
    with_headers = frames.total_bytes + 2 * frames.transactions * TCP_IP_ETHERNET_OVERHEAD_BYTES
    ethernet = with_headers * 8 * ETHERNET_BIT_S
    return (
        f"{head}   frames {frames.request_bytes}+{frames.response_bytes} B, loopback: "
        f"no wire; at 100 Mbit/s {ethernet * 1e6:5.1f} us  ratio {median / ethernet:6.1f}"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--polls", type=int, default=200, help="polls per configuration")
    args = parser.parse_args()
    logging.basicConfig(level=logging.WARNING)
    print("three-axis status poll, simulated controller, pymodbus on both ends, one process")
    print("RTU: 38400 baud 8N1 paced by the pty bridge in both directions")
    for profile_name in ("iai-pcon", "cia402"):
        for transport in ("tcp", "rtu"):
            print(bench(profile_name, transport, args.polls))


if __name__ == "__main__":
    main()
