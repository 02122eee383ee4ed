"""How the suite's files load two workers (prints figures; not a test).

Reads the seconds each test file took in the last whole run of the suite on this checkout
(pytest's cache, ``ogacq/file_seconds``, kept by tests/balance.py) and prints the longest
files, their total, and what two workers taking the files longest first end at (the
wall time the files alone make, without start-up) beside one worker's whole.

    python bench/suite_balance.py [N]     # the N longest files (default 25)
    python bench/suite_balance.py --write # those seconds into tests/file_seconds.json,
                                          # the order a fresh clone (CI) starts from
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
CACHE = ROOT / ".pytest_cache" / "v" / "ogacq" / "file_seconds"
COMMITTED = ROOT / "tests" / "file_seconds.json"
# Files under this many seconds keep their collection order: not worth a line.
KEEP_ABOVE_S = 1.0


def two_workers(seconds: list[float]) -> float:
    """When the later of two workers ends, each taking the next file as it is free."""
    loads = [0.0, 0.0]
    for s in seconds:
        loads[loads.index(min(loads))] += s
    return max(loads)


def main(argv: list[str]) -> int:
    if not CACHE.is_file():
        print(f"no {CACHE.relative_to(ROOT)}: run the whole suite once (python -m pytest)")
        return 1
    seconds: dict[str, float] = json.loads(CACHE.read_text())
    ranked = sorted(seconds.items(), key=lambda kv: -kv[1])
    if argv[:1] == ["--write"]:
        kept = {name: round(s, 1) for name, s in ranked if s > KEEP_ABOVE_S}
        COMMITTED.write_text(json.dumps(kept, indent=1) + "\n")
        print(f"{len(kept)} files over {KEEP_ABOVE_S} s written to "
              f"{COMMITTED.relative_to(ROOT)}")
        return 0
    shown = int(argv[0]) if argv else 25
    for name, s in ranked[:shown]:
        print(f"{s:8.1f} s  {name}")
    total = sum(seconds.values())
    print(f"{len(seconds)} files, {total:.0f} s in all; two workers, longest first: "
          f"{two_workers([s for _, s in ranked]):.0f} s (the longest file "
          f"{ranked[0][1]:.0f} s)")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
