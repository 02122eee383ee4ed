"""Benchmark of the mismatch diagnosis on a corpus of campaigns (prints figures; not a
test).

Each campaign is written as a readings CSV and a machine file (or is a session or a
published table) and diagnosed as ``ogacq diagnose`` reads it (``load_input``). Per
campaign: the diagnosis in process, warm (median of N after one untimed run), and one
cold run of ``python -m ogacq diagnose FILE --json`` in a fresh process, beside
numpy's import measured in the same run (as ``bench_startup.py``: a fresh
``PYTHONPYCACHEPREFIX``, one untimed run first, so every module runs from bytecode).

``--dump DIR`` writes every campaign's ``diagnose --json`` and terminal text
(``COLUMNS=100``) to DIR: dump the code before a change, then after, and compare
(``diff -r``): a speed-up must leave both identical.

``--scipy``: also the first step's 378 candidates fitted one at a time with
``scipy.optimize.least_squares`` (numerical Jacobians) beside the diagnosis of the
72-reading campaign; that loop covers less than the diagnosis does, so the ratio
understates the gain.

Run: python bench/bench_diagnose.py [N, default 5] [--dump DIR] [--scipy] [--only NAME]
"""

from __future__ import annotations

import argparse
import fcntl
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(ROOT))  # the tests' campaign helpers

import numpy as np  # noqa: E402
from bench_linear import MACHINE as BENCH_MACHINE  # noqa: E402
from bench_linear import campaign  # noqa: E402

from ogacq.diagnose.diagnosis import diagnose  # noqa: E402
from ogacq.identify.observations import Observations  # noqa: E402
from ogacq.io.loading import load_input  # noqa: E402
from ogacq.io.machine_file import read_machine, write_machine  # noqa: E402
from ogacq.io.tables import write_readings  # noqa: E402
from ogacq.model.machine import MachineSpec  # noqa: E402
from ogacq.model.parameters import PARAM_SETS  # noqa: E402

PAPER = ROOT / "ogacq" / "examples" / "paper"
SESSION = ROOT / "tests" / "golden" / "session.jsonl"
FOLDER = Path(tempfile.gettempdir(), "bench_diag1")


@dataclass(frozen=True)
class Case:
    """A campaign as ``ogacq diagnose`` is given it: a file and, for readings, a machine."""
    name: str
    file: Path
    machine: Path | None


def _simulated() -> dict[str, Callable[[], tuple[Observations, MachineSpec]]]:
    from ogacq.sim.truth import Hysteresis, LeadScrewError, ScrewMap
    from tests.diagnose.campaigns import MACHINE, RICH, layout, simulate
    from tests.diagnose.test_maps import campaign as scan
    from tests.diagnose.test_unexplained import LEAD_SCREW

    return {
        "bench72": lambda: (campaign(72), BENCH_MACHINE),
        "bench720": lambda: (campaign(720), BENCH_MACHINE),
        "clean": lambda: (simulate({}, 1), MACHINE),
        "leg_lengths": lambda: (simulate({"leg_length.y": 0.3, "leg_length.z": -0.2}, 3),
                                MACHINE),
        "backlash_rich": lambda: (simulate({"backlash.x": 0.02}, 3, lay=layout(RICH)), MACHINE),
        "lead_screw_unexplained": lambda: (simulate({}, 4, lead_screw=LEAD_SCREW), MACHINE),
        "scan_screw_map": lambda: (scan(8, scan={"scan_step_mm": 1.0, "cycles": 2},
                                        screw_map={1: ScrewMap((0.0, 0.0, 0.05))})[0],
                                   MACHINE),
        "scan_cyclic": lambda: (scan(5, lead_screw={0: LeadScrewError(0.005, 5.0, 30.0)})[0],
                                MACHINE),
        "scan_hysteresis": lambda: (scan(5, hysteresis={2: Hysteresis(0.02, 6.0)})[0],
                                    MACHINE),
    }


def corpus(folder: Path) -> list[Case]:
    cases = []
    for name, make in _simulated().items():
        obs, machine = make()
        readings, machine_file = folder / f"{name}.csv", folder / f"{name}.toml"
        write_readings(readings, obs.layout, obs.values)
        write_machine(machine_file, machine, f"bench_diagnose: {name}")
        cases.append(Case(name, readings, machine_file))
    for table in ("experiment1_6", "experiment2_12", "experiment3_12"):
        cases.append(Case(f"paper_{table}", PAPER / f"{table}.csv", PAPER / "machine.toml"))
    session = folder / "session.jsonl"
    shutil.copy(SESSION, session)  # a session: its diagnosis is recorded in a history
    cases.append(Case("golden_session", session, None))
    return cases


def observations(case: Case) -> Observations:
    spec = read_machine(case.machine) if case.machine is not None else None
    return load_input(case.file, spec, PARAM_SETS["offsets"],
                      machine_path=case.machine).observations


def argv(case: Case, *extra: str) -> list[str]:
    machine = ["--machine", str(case.machine)] if case.machine is not None else []
    return [sys.executable, "-m", "ogacq", "diagnose", str(case.file), *machine, *extra]


def run(command: list[str], env: dict[str, str], folder: Path) -> tuple[float, str]:
    history = folder / "history.sqlite"
    history.unlink(missing_ok=True)  # each run records into an empty history
    start = time.perf_counter()
    proc = subprocess.run([*command, "--history", str(history)] if "diagnose" in command
                          else command, capture_output=True, text=True, env=env, check=True)
    return time.perf_counter() - start, proc.stdout


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("runs", nargs="?", type=int, default=5)
    parser.add_argument("--dump", type=Path)
    parser.add_argument("--scipy", action="store_true")
    parser.add_argument("--only", action="append", default=[])
    args = parser.parse_args()
    # one fixed folder: the outputs name their files, and dumps of two runs compare;
    # a second run at once waits for the first instead of deleting its folder
    lock = FOLDER.with_suffix(".lock").open("a")
    fcntl.flock(lock, fcntl.LOCK_EX)
    folder = FOLDER
    shutil.rmtree(folder, ignore_errors=True)
    folder.mkdir()
    try:
        cases = [c for c in corpus(folder) if not args.only or c.name in args.only]
        env = dict(os.environ, COLUMNS="100")
        env.pop("PYTHONDONTWRITEBYTECODE", None)
        env["PYTHONPYCACHEPREFIX"] = str(folder / "pycache")
        numpy_import = [sys.executable, "-c", "import numpy"]
        run(numpy_import, env, folder)
        run(argv(cases[0], "--json"), env, folder)  # bytecode written, untimed
        if args.dump:
            args.dump.mkdir(parents=True, exist_ok=True)
        print(f"{'campaign':24s} {'readings':>8s} {'warm median':>12s} {'cold CLI':>9s} "
              f"{'numpy import':>13s}  cold/numpy")
        total_warm = total_cold = 0.0
        for case in cases:
            obs = observations(case)
            diagnose(obs)  # warm
            times = []
            for _ in range(args.runs):
                start = time.perf_counter()
                diagnose(obs)
                times.append(time.perf_counter() - start)
            numpy_s, _ = run(numpy_import, env, folder)
            cold_s, out = run(argv(case, "--json"), env, folder)
            warm = statistics.median(times)
            total_warm, total_cold = total_warm + warm, total_cold + cold_s
            print(f"{case.name:24s} {len(obs):8d} {warm * 1e3:9.1f} ms {cold_s:7.3f} s "
                  f"{numpy_s:11.3f} s  {cold_s / numpy_s:6.2f}x", flush=True)
            if args.dump:
                (args.dump / f"{case.name}.json").write_text(out)
                _, text = run(argv(case), env, folder)
                (args.dump / f"{case.name}.txt").write_text(text)
        print(f"{'total':24s} {'':8s} {total_warm * 1e3:9.1f} ms {total_cold:7.3f} s")
        if args.scipy:
            scipy_comparison()
    finally:
        shutil.rmtree(folder, ignore_errors=True)
        lock.close()  # the lock goes with it


def scipy_comparison() -> None:
    from scipy.optimize import least_squares

    from ogacq.diagnose.library import BASE_MODEL, pairs, singles
    from ogacq.model.parameters import NOMINAL, indices

    obs = campaign(72)
    start = time.perf_counter()
    result = diagnose(obs)
    ours = time.perf_counter() - start
    start = time.perf_counter()
    best: tuple[float, tuple[str, ...]] = (np.inf, ())
    for extra in singles() + pairs():
        free = indices(BASE_MODEL + extra)

        def residual(x: np.ndarray, free: np.ndarray = free) -> np.ndarray:
            theta = NOMINAL.copy()
            theta[free] = x
            return obs.remove_zeros(obs.values - obs.predict(theta))

        fitted = least_squares(residual, NOMINAL[free], jac="2-point", x_scale="jac")
        best = min(best, (float(np.sum(fitted.fun**2)), extra))
    plain = time.perf_counter() - start
    print(f"plain least_squares loop over the first step's 378 candidates: {plain:.1f} s, "
          f"{plain / ours:.0f}x the whole diagnosis ({ours:.2f} s); its best "
          f"{' + '.join(best[1])} (rss {best[0]:.3g} mm^2, ours "
          f"{result.selection.steps[0].after.rss:.3g})")


if __name__ == "__main__":
    main()
