"""Stable-reading rate of a simulated 01A gauge against the serial line limit.

A 01A exchange is the request (``1\\r``, 2 bytes) and the reply (13 bytes); at
9600 baud 8N1 (10 bits a byte) the line carries at most 9600 / (15 x 10) = 64
exchanges a second, so ``read_stable`` with N consecutive values can give at
most 64 / N stable readings a second. The simulated gauge paces both
directions at the baud rate (a pty would otherwise be instantaneous), so the
ratio printed is what the driver and endpoint waste on top of the line.

Run: ``python bench/bench_gauge_rate.py [--seconds 3] [--n 3]``. Target >= 90 %.
"""

from __future__ import annotations

import argparse
import sys
import time

from ogacq_drivers.indicators import open_indicator, read_stable
from ogacq_drivers.indicators.mitutoyo_01a import encode_reply, encode_request
from ogacq_drivers.sim.gauges import GaugeEndpoint

TARGET_RATIO = 0.90


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=3.0, help="measuring time")
    parser.add_argument("--n", type=int, default=3, help="consecutive values per stable reading")
    parser.add_argument("--baud", type=int, default=9600)
    parser.add_argument("--transport", choices=("pty", "socket"), default="pty")
    args = parser.parse_args(argv)

    value_mm = 12.345
    with GaugeEndpoint(
        "mitutoyo-01a", lambda: value_mm, baud=args.baud, transport=args.transport
    ) as endpoint:
        gauge = open_indicator("mitutoyo-01a", endpoint.port, unit="mm", where="bench gauge")
        try:
            read_stable(gauge, n=args.n, tolerance_mm=0.002, timeout_s=2.0)  # warm up
            requests_before = endpoint.requests_received
            stable = 0
            start = time.perf_counter()
            while time.perf_counter() - start < args.seconds:
                read_stable(gauge, n=args.n, tolerance_mm=0.002, timeout_s=2.0)
                stable += 1
            elapsed = time.perf_counter() - start
            exchanges = endpoint.requests_received - requests_before
        finally:
            gauge.close()

    exchange_bytes = len(encode_request("1")) + len(encode_reply(value_mm, decimals=3))
    bits_per_byte = endpoint.settings.bits_per_byte
    line_exchanges_per_s = args.baud / (exchange_bytes * bits_per_byte)
    line_stable_per_s = line_exchanges_per_s / args.n
    stable_per_s = stable / elapsed
    ratio = stable_per_s / line_stable_per_s

    print(f"01A gauge on {args.transport}, {args.baud} baud 8N1 ({bits_per_byte} bits/byte)")
    print(f"exchange: {exchange_bytes} bytes (request + reply), N = {args.n} per stable reading")
    print(
        f"line limit: {line_exchanges_per_s:.2f} exchanges/s = "
        f"{line_stable_per_s:.2f} stable readings/s"
    )
    print(
        f"measured:   {exchanges / elapsed:.2f} exchanges/s = "
        f"{stable_per_s:.2f} stable readings/s ({stable} in {elapsed:.2f} s)"
    )
    print(f"ratio:      {ratio:.1%} of the line limit (target {TARGET_RATIO:.0%})")
    return 0 if ratio >= TARGET_RATIO else 1


if __name__ == "__main__":
    sys.exit(main())
