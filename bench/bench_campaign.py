"""Benchmark: the papers' campaign beside its physical floor (prints figures; not a test).

Every campaign runs through the real drivers against `ogacq sim` in its own
process (an in-process simulator would bill its own physics to the campaign), on
the simulator's ringing machine (a damped vibration after every move,
`ogacq/sim/truth.py:Vibration`, stated below), seed 1 for every run.

1. Overhead per reading, the machine loaded as CI loads it: a second process the
   bench starts itself keeps one of the cores busy, the simulator at x25. From
   the wall time we subtract the simulated motion (trapezoidal moves plus the
   drive's in-position delay), the settle the rule took (machine clock, the
   gauges' exchanges during it included) and the gauge line time of the readings
   after it (each request and reply at 9600 baud; the gauges of a posture read
   at once, so a step costs its slowest line). What remains, per reading, is the
   campaign's own: runner, session writes, Modbus transactions of verified moves
   and status polls, frame parsing, the simulated devices' response. Target:
   under 5 ms (the cores other processes kept busy meanwhile, the machine's busy
   time less the bench's own, are printed with it). Beside it, the physical
   floor: motion + the settle the ringing needs (its time constant times
   ln(amplitude / (u / 3)), from the stated vibration: until under a third of the
   gauges' standard uncertainty u = sqrt(noise^2 + q^2 / 12), the stable rule's
   target) + the line time of one stable reading per step. The floor waits for the
   largest drawn amplitude to decay; the stable rule reads during the decay and
   averages whole periods of the ringing, so it can end at or below this floor.
2. In real time (x1, unloaded): the runner as it was before (a fixed settle
   before every reading step, moved or not, gauges read one after the other),
   `settle = "fixed"` and `settle = "stable"` (the default): wall time, the
   identified offsets and their std. Target: stable at least 30 % shorter than
   before, the offsets unchanged within their std. The gauges are 10 um dials
   (q = 0.01 mm); `bench_settle_sweep.py` runs 1 um gauges over several seeds.
3. The fixed cost of a 72-reading refit beside the plain numpy Gauss-Newton floor
   (`numpy_floor.py`, the same readings as `bench_linear.py`). Target: 1.5x.

Run: python bench/bench_campaign.py [--quick: skip the real-time runs]
"""

from __future__ import annotations

import json
import math
import os
import signal
import subprocess
import sys
import tempfile
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_linear import OFFSETS, campaign, floor_of, seconds  # noqa: E402

from ogacq.campaign.campaign_file import read_campaign  # noqa: E402
from ogacq.campaign.run import identify_session  # noqa: E402
from ogacq.campaign.station import open_station  # noqa: E402
from ogacq.identify.fit import fit  # noqa: E402
from ogacq.identify.observations import readings_observations  # noqa: E402
from ogacq.protocol.plan import Read  # noqa: E402
from ogacq.protocol.runner import CampaignRunner  # noqa: E402
from ogacq.session.convert import machine_dict  # noqa: E402
from ogacq.session.records import MoveRecord, SettleRecord  # noqa: E402
from ogacq.session.store import SessionWriter, load_session  # noqa: E402
from ogacq.sim.truth import SimTruth, Vibration  # noqa: E402

BAUD_BYTE_S = 10 / 9600
EXCHANGE_S = 15 * BAUD_BYTE_S  # 01A: "1\r" and "01A+0000.123\r"
# the simulator's motion model defaults (drivers/sim/motion.py)
SPEED_MM_S, ACCEL_MM_S2, MOTION_SETTLE_S = 100.0, 2000.0, 0.02
RESOLUTION_MM = 0.01  # 10 um dials
NOISE_MM = SimTruth.noise_mm  # the simulator's gauges' scatter (ogacq sim's default)
MACHINE = "leg_length_mm = 310.25\nrho_min_mm = -100.0\nrho_max_mm = 60.0\n" \
          f"gauge_resolution_mm = {RESOLUTION_MM}\n"
SETTLE_S, WINDOW_S = 1.0, 0.1  # machine seconds
RINGING = Vibration()


def move_time_s(distance_mm: float) -> float:
    if distance_mm <= 0:
        return 0.0
    if distance_mm <= SPEED_MM_S**2 / ACCEL_MM_S2:
        return 2 * math.sqrt(distance_mm / ACCEL_MM_S2)
    return distance_mm / SPEED_MM_S + SPEED_MM_S / ACCEL_MM_S2


class BeforeRunner(CampaignRunner):
    """The runner before issue 14's rest: a fixed settle before every reading step,
    moved or not, then the gauges one after the other."""

    moved = 0  # steps after a move: where the ringing needs its time

    def _read_step(self, step: Read, *, settle: bool) -> None:
        self.moved += settle
        self.station.settle(self.config.settle_s)
        for gauge in step.gauges:
            if (step.step, gauge) not in self.recorded:
                self._read_gauges(step, [gauge], {})


class LineTimer:
    """Wraps the station: counts each gauge's exchanges and the line time of the reads
    outside a settle (per step the slowest line, the gauges being read at once)."""

    def __init__(self, station) -> None:
        self.station = station
        self.exchanges = dict.fromkeys(station.indicators, 0)
        self.line_s = 0.0
        for gauge, indicator in station.indicators.items():
            read = indicator.read

            def counted(*args, _read=read, _gauge=gauge, **kwargs):
                self.exchanges[_gauge] += 1
                return _read(*args, **kwargs)

            indicator.read = counted
        self._plain = station.read_gauges
        station.read_gauges = self.read_gauges

    def read_gauges(self, step, gauges, rule):
        before = dict(self.exchanges)
        out = self._plain(step, gauges, rule)
        self.line_s += max(self.exchanges[g] - before[g] for g in gauges) * EXCHANGE_S
        return out


def cpu_seconds(pid: int | str) -> float:
    """CPU time (user + system) a process has used, its threads and reaped children
    included (Linux /proc)."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return sum(int(v) for v in fields[11:15]) / os.sysconf("SC_CLK_TCK")


def machine_busy_s() -> float:
    """CPU seconds all cores have been busy since boot (/proc/stat: all but idle, iowait)."""
    values = [int(v) for v in Path("/proc/stat").read_text().split("\n", 1)[0].split()[1:]]
    return (sum(values) - values[3] - values[4]) / os.sysconf("SC_CLK_TCK")


class LoadMeter:
    """The cores other processes kept busy while a campaign ran: the machine's busy
    time less that of the bench, its simulator and its load process, over the wall time."""

    def __init__(self, *pids: int) -> None:
        self.pids = ["self", *pids]
        self.start = time.perf_counter()
        self.busy, self.own = machine_busy_s(), self._own()

    def _own(self) -> float:
        return sum(cpu_seconds(pid) for pid in self.pids)

    def others_cores(self) -> float:
        wall = time.perf_counter() - self.start
        return max(0.0, (machine_busy_s() - self.busy) - (self._own() - self.own)) / wall


LOAD_PID: list[int] = []  # the bench's own load process, while it runs


def start_simulator(speed: float) -> tuple[subprocess.Popen, dict]:
    # Ctrl-C stops it: a bench run in the background (nohup, &) hands its children
    # SIGINT ignored, and Python then installs no handler for it
    proc = subprocess.Popen([sys.executable, "-m", "ogacq", "sim", "--speed", str(speed),
                             "--seed", "1", "--json"], stdout=subprocess.PIPE,
                            start_new_session=True, text=True,
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    return proc, json.loads(proc.stdout.readline())


def campaign_text(info: dict, speed: float, settle: str, session: str) -> str:
    m = info["modbus"]
    lines = ['machine = "machine.toml"', f'session = "{session}"', "[controller]",
             f'profile = "{m["profile"]}"', f'port = "{m["host"]}:{m["port"]}"',
             # the external simulator keeps its own clock: real seconds here
             "[protocol]", f'settle = "{settle}"', f"settle_s = {SETTLE_S / speed}",
             f"settle_window_s = {WINDOW_S / speed}"]
    for key, g in info["gauges"].items():
        lines += ["[[gauges]]", f'gauge = "{key}"', f'protocol = "{g["protocol"]}"',
                  f'port = "{g["port"]}"']
    return "\n".join(lines) + "\n"


def run(folder: Path, speed: float, settle: str, runner_class=CampaignRunner) -> dict:
    """One papers' campaign against a fresh `ogacq sim`; its figures."""
    proc, info = start_simulator(speed)
    name = f"{runner_class.__name__}-{settle}-x{speed:g}"
    try:
        path = folder / f"{name}.toml"
        path.write_text(campaign_text(info, speed, settle, f"{name}.jsonl"))
        campaign = read_campaign(path)
        with open_station(campaign) as station:
            station.prepare()
            timer = LineTimer(station)
            header = {"plan": campaign.protocol.to_dict(),
                      "machine": machine_dict(campaign.machine)}
            with SessionWriter.create(campaign.session, header) as writer:
                runner = runner_class(station, writer, campaign.protocol, campaign.machine)
                meter = LoadMeter(proc.pid, *LOAD_PID)
                start = time.perf_counter()
                runner.run()
                wall = time.perf_counter() - start
                others = meter.others_cores()
    finally:
        os.killpg(proc.pid, signal.SIGINT)
        try:
            proc.wait(30)
        except subprocess.TimeoutExpired:  # a last resort: the figures are kept
            print("   (the simulator did not stop within 30 s of Ctrl-C: killed)",
                  file=sys.stderr)
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
    session = load_session(campaign.session)
    motion, last = 0.0, (0.0, 0.0, 0.0)
    for move in session.of_type(MoveRecord):
        motion += move_time_s(max(abs(a - b) for a, b in zip(move.q_mm, last, strict=True))) \
            + MOTION_SETTLE_S
        last = tuple(move.q_mm)
    settles = session.of_type(SettleRecord)
    if runner_class is BeforeRunner:
        settle_s = sum(1 for s in runner._steps if isinstance(s, Read)) * campaign.protocol.settle_s
        moved = runner.moved
    else:
        settle_s = sum(r.waited_s for r in settles)
        moved = sum(1 for r in settles if r.rule != "none")
    steps = sum(1 for s in runner._steps if isinstance(s, Read))
    u_mm = math.hypot(NOISE_MM, RESOLUTION_MM / math.sqrt(12))
    needed = RINGING.time_constant_s * math.log(RINGING.amplitude_mm / (u_mm / 3))
    result = identify_session(session)
    return {"wall": wall, "others": others, "readings": runner.total_readings,
            "moves": len(session.of_type(MoveRecord)), "motion": motion / speed, "settle": settle_s,
            "line": timer.line_s, "exchanges": sum(timer.exchanges.values()),
            "floor": motion / speed + moved * needed / speed
            + steps * campaign.protocol.stability.readings * EXCHANGE_S,
            "ended": {e: sum(1 for r in settles if r.ended == e)
                      for e in ("stable", "bound", "time", "not moved")},
            "offsets": result.values, "std": result.std}


def offsets_text(r: dict) -> str:
    return " ".join(f"{v:+.4f}+-{s:.4f}" for v, s in zip(r["offsets"], r["std"], strict=True))


def overhead(folder: Path) -> None:
    load = subprocess.Popen([sys.executable, "-c", "while True: pass"])
    LOAD_PID.append(load.pid)
    try:
        runs = {"stable": run(folder, 25.0, "stable"),
                "before": run(folder, 25.0, "fixed", BeforeRunner)}
    finally:
        LOAD_PID.clear()
        load.kill()
        load.wait()
    print(f"1. overhead (x25, one core kept busy by a second process, {os.cpu_count()} cores, "
          "and the cores other processes kept busy meanwhile, measured; the runner as it "
          "was before beside it, same load):")
    for name, r in runs.items():
        rest = r["wall"] - r["motion"] - r["settle"] - r["line"]
        per = rest / r["readings"] * 1000
        print(f"   {name:<7} {r['readings']} readings, {r['moves']} moves in {r['wall']:.2f} s "
              f"wall = motion {r['motion']:.2f} s + settle taken {r['settle']:.2f} s + gauge "
              f"line after it {r['line']:.2f} s + overhead {rest:.2f} s = {per:.2f} ms per "
              f"reading (target < 5 ms); other processes {r['others']:.2f} cores")
    r = runs["stable"]
    print(f"   physical floor (motion + ringing to u / 3 + one stable reading's line "
          f"time per step) {r['floor']:.2f} s: stable's wall / floor {r['wall'] / r['floor']:.2f};"
          f" its settles {r['ended']}")
    print(f"   stable's offsets x y z mm {offsets_text(r)}")


def real_time(folder: Path) -> None:
    print(f"2. real time (x1, unloaded; ringing {RINGING.amplitude_mm * 1000:g} um, time "
          f"constant {RINGING.time_constant_s:g} s, {RINGING.frequency_hz:g} Hz; settle_s "
          f"{SETTLE_S:g}, window {WINDOW_S:g} s):")
    runs = {"before": run(folder, 1.0, "fixed", BeforeRunner),
            "fixed": run(folder, 1.0, "fixed"), "stable": run(folder, 1.0, "stable")}
    before = runs["before"]["wall"]
    for name, r in runs.items():
        offsets = offsets_text(r)
        print(f"   {name:<7} {r['wall']:6.1f} s ({1 - r['wall'] / before:+6.1%} vs before), "
              f"floor {r['floor']:5.1f} s, motion {r['motion']:4.1f} s, settle "
              f"{r['settle']:4.1f} s; offsets x y z mm {offsets}")
    fixed, stable = runs["fixed"], runs["stable"]
    shift = np.abs(stable["offsets"] - fixed["offsets"]) / fixed["std"]
    std_ratio = stable["std"] / fixed["std"]
    print(f"   stable vs fixed: offsets differ by {np.max(shift):.2f} std at most, std ratio "
          f"{np.min(std_ratio):.2f}..{np.max(std_ratio):.2f}; stable vs before "
          f"{1 - stable['wall'] / before:.1%} shorter (target >= 30 %)")


def refit_fixed_cost() -> None:
    obs = campaign(72)
    fit(obs, OFFSETS)  # warm
    refit_s = seconds(lambda: fit(obs, OFFSETS), 200)
    floor = floor_of(obs)
    floor_s = seconds(floor.fit, 200)
    diff = float(np.max(np.abs(fit(obs, OFFSETS).values - floor.fit())))
    print(f"3. refit at 72 readings: {refit_s * 1e3:.2f} ms, numpy floor {floor_s * 1e3:.2f} ms,"
          f" ratio {refit_s / floor_s:.2f} (target 1.5), offsets differ by {diff:.1e} mm")
    # Both above have their data set prepared (the floor's constructor takes the repeat
    # groups and noise; the fit remembers them per data set). A new data set, as a
    # refit of a file in a new process has, builds them too:
    cold_s = seconds(lambda: fit(readings_observations(obs.machine, replace(obs.layout),
                                                       obs.values.copy()), OFFSETS), 200)
    print(f"   a new data set's refit (observations, repeat groups, noise built too): "
          f"{cold_s * 1e3:.2f} ms, {cold_s / floor_s:.2f} x the floor's fit alone")


def main() -> None:
    folder = Path(tempfile.mkdtemp(prefix="ogacq-bench-"))
    (folder / "machine.toml").write_text(MACHINE)
    overhead(folder)
    if "--quick" not in sys.argv:
        real_time(folder)
    refit_fixed_cost()


if __name__ == "__main__":
    main()
