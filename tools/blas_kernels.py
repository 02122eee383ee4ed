"""Run the numerical tests under other OpenBLAS kernels before landing (issue 27).

A BLAS kernel, a CPU or a thread count must not change a verdict of the suite.
numpy's wheels carry OpenBLAS built for every x86 kernel and pick one for the CPU
at start; ``OPENBLAS_CORETYPE`` makes it pick another, so one machine can run the
numerical tests as an older or a newer CPU would. CI itself leaves the machine's
setting alone; this script is run by hand before a change to the numerics lands::

    python tools/blas_kernels.py                  # Sandybridge and Prescott
    python tools/blas_kernels.py Haswell SkylakeX -- tests/identify

Each kernel's run is checked to have taken the kernel asked for (OpenBLAS says
which core it chose when ``OPENBLAS_VERBOSE=2``). Exit 0 when every run passed.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
KERNELS = ("Sandybridge", "Prescott")
NUMERICAL_TESTS = ("tests/identify", "tests/model", "tests/diagnose", "tests/uncertainty")
# OpenBLAS names some kernels after the core it then reports (Prescott runs as Katmai)
REPORTED = {"Prescott": "Katmai", "Core2": "Katmai"}


def chosen_core(kernel: str) -> str:
    env = {**os.environ, "OPENBLAS_CORETYPE": kernel, "OPENBLAS_VERBOSE": "2"}
    out = subprocess.run([sys.executable, "-c", "import numpy"], env=env, capture_output=True,
                         text=True, check=False)
    for line in (out.stdout + out.stderr).splitlines():
        if line.startswith("Core:"):
            return line.split(":", 1)[1].strip()
    return ""


def main(argv: list[str]) -> int:
    kernels, tests = (argv[:argv.index("--")], argv[argv.index("--") + 1:]) \
        if "--" in argv else (argv, [])
    kernels = kernels or list(KERNELS)
    tests = tests or list(NUMERICAL_TESTS)
    outcome: dict[str, str] = {}
    for kernel in kernels:
        core = chosen_core(kernel)
        if core != REPORTED.get(kernel, kernel):
            outcome[kernel] = (f"not run: OpenBLAS chose core {core or 'unknown'!r} "
                               f"(numpy without OpenBLAS's DYNAMIC_ARCH, or no such kernel)")
            continue
        print(f"== OPENBLAS_CORETYPE={kernel} (core {core}): {' '.join(tests)}", flush=True)
        env = {**os.environ, "OPENBLAS_CORETYPE": kernel}
        run = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider",
                              *tests], cwd=ROOT, env=env, check=False)
        outcome[kernel] = "passed" if run.returncode == 0 else f"FAILED (exit {run.returncode})"
    print()
    for kernel, result in outcome.items():
        print(f"{kernel:14s} {result}")
    return 0 if all(r == "passed" for r in outcome.values()) else 1


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
