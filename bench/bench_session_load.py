#!/usr/bin/env python3
"""Benchmark (not a test): the CPU a session's reading costs, as a calibration reads
its campaigns' sessions again and again (after the fit, the record, the history).

    python bench/bench_session_load.py [--readings 6000]

Writes a sealed session of READINGS readings (the size of a designed scan's, about
1.7 MB) and prints, each the least CPU time of 3 (``time.process_time``):

- ``cold``: ``load_session`` as a new process reads it (no line decoded before);
- ``again``: read again unchanged (``ogacq.session.seal``'s lines decoded before);
- ``appended``: read again after one record is appended (what a campaign does after
  its fit);
- ``typed``: ``record_from_json`` of every line alone (``ogacq.io.declared``'s checks).
"""

from __future__ import annotations

import argparse
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

from ogacq.session import seal
from ogacq.session.records import EndRecord, ReadingRecord, record_from_json
from ogacq.session.store import SessionWriter, load_session


def reading(k: int) -> ReadingRecord:
    return ReadingRecord.from_json({
        "step": f"x/c1/p{k}", "gauge": "y_x", "leg": "x", "gauge_axis": "y", "cycle": 1,
        "posture": f"{k % 125}", "t_s": 1.5 * k, "q_mm": [0.1 * k, 0.0, 0.0],
        "tcp_mm": [0.1, 0.2, 0.3], "approach": [1, 0, 0], "reading_mm": 5.0 + 1e-6 * k,
        "raw": "01A+00005.0012\r", "source": "sim:0", "averaged": 3,
        "averaged_sd_mm": 0.0004})


def least(run: Callable[[], object], before: Callable[[], object] = lambda: None) -> float:
    best = float("inf")
    for _ in range(3):
        before()
        start = time.process_time()
        run()
        best = min(best, time.process_time() - start)
    return best


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--readings", type=int, default=6000)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "session.jsonl"
        with SessionWriter.create(path, {"machine": {"leg_length_mm": 310.25}}) as writer:
            for k in range(args.readings):
                writer.write(reading(k))
        size = path.stat().st_size
        # a version before the lines decoded were kept has none to forget
        cold = least(lambda: load_session(path), getattr(seal, "_DECODED", {}).clear)
        load_session(path)
        again = least(lambda: load_session(path))

        def append() -> None:  # after a reading: the earlier lines decoded, the new not
            with SessionWriter.append_to(path) as more:
                more.write(EndRecord(status="stopped", reason="bench"))
        appended = least(lambda: load_session(path), append)
        lines = [r for _, r in seal.scan_session(path).records[1:]]
        typed = least(lambda: [record_from_json(r) for r in lines])
    print(f"{args.readings} readings, {size / 1e6:.1f} MB; CPU, least of 3:")
    print(f"  cold      {cold:.3f} s")
    print(f"  again     {again:.3f} s")
    print(f"  appended  {appended:.3f} s")
    print(f"  typed     {typed:.3f} s ({typed / len(lines) * 1e6:.1f} µs a record)")


if __name__ == "__main__":
    main()
