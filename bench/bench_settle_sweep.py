"""Benchmark: is the stable settle as safe as the fixed wait on 1 um indicators? (not a test)

The papers' campaign (72 readings) on 1 um gauges (display step 0.001 mm, the
simulator's noise 1 um), on the ringing simulator (`ogacq/sim/truth.py:Vibration`:
5-10 um at 20 Hz, time constant 0.15 s after every move), run once with
`settle = "fixed"` and once with `settle = "stable"` for each seed, in real time
(`--speed` to change it; above x1 the gauges, read more sparsely in machine time,
show the ringing's mean between their values: `ogacq/sim/machine.py:vibration_mm`).

For each run it prints: the campaign's wall time and the settle time the rule
took; the identified joint offsets with their std, and stable's shift from fixed
in units of the std of a difference of two independent estimates (sqrt(std_f^2 +
std_s^2)), and each rule's miss of the simulator's hidden offsets in units of its own
std; the lack-of-fit verdict (F, dof, p) with the noise
measured from the repeats; and the readings' error against the simulator's
truth (each reading less what the gauge would show were the machine still,
noiseless and unrounded), as an rms in um and in units of the gauge's standard
uncertainty u = sqrt(noise^2 + q^2 / 12) (the whole error: noise, rounding and
any ringing left; a ringing of u / 3 would add 6 % to its square). Target: the
offsets within their std of fixed's, the p-values not systematically lower, the
error rms as with fixed, the misses of the truth within a few std for both.

Run: python bench/bench_settle_sweep.py [--seeds 1,2,3,4,5] [--speed 1]
"""

from __future__ import annotations

import argparse
import math
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from ogacq.campaign.campaign_file import read_campaign
from ogacq.campaign.run import identify_session
from ogacq.campaign.station import open_station
from ogacq.identify.consistency import fit_verdict
from ogacq.model.gauges import Gauge
from ogacq.protocol.runner import CampaignRunner
from ogacq.session.convert import machine_dict
from ogacq.session.records import SettleRecord
from ogacq.session.store import SessionWriter, load_session

RESOLUTION_MM, NOISE_MM = 0.001, 0.001
MACHINE = ("leg_length_mm = 310.25\nrho_min_mm = -100.0\nrho_max_mm = 60.0\n"
           f"gauge_resolution_mm = {RESOLUTION_MM}\n")
U_MM = math.sqrt(NOISE_MM**2 + RESOLUTION_MM**2 / 12)


class TruthRunner(CampaignRunner):
    """Records, beside each reading, its error against the simulator's truth."""

    errors_mm: list[float]

    def _record(self, step, gauge, value) -> None:
        g = Gauge.parse(gauge)
        truth = self.station.simulator.machine.rest_value_mm(*g.indices)
        self.errors_mm.append(value.value_mm - truth)
        super()._record(step, gauge, value)


def run(folder: Path, seed: int, settle: str, speed: float) -> dict:
    name = f"seed{seed}-{settle}"
    path = folder / f"{name}.toml"
    path.write_text(f'machine = "machine.toml"\nsession = "{name}.jsonl"\n\n'
                    f'[protocol]\nsettle = "{settle}"\nsettle_s = 1.0\nsettle_window_s = 0.1\n\n'
                    f"[simulator]\nseed = {seed}\nspeed = {speed}\nnoise_mm = {NOISE_MM}\n")
    campaign = read_campaign(path)
    with open_station(campaign) as station:
        station.prepare()
        hidden = station.simulator.machine.truth.hidden()
        truth = np.array([hidden.get(f"joint_offset.{a}", 0.0) for a in "xyz"])
        header = {"plan": campaign.protocol.to_dict(), "machine": machine_dict(campaign.machine)}
        with SessionWriter.create(campaign.session, header) as writer:
            runner = TruthRunner(station, writer, campaign.protocol, campaign.machine)
            runner.errors_mm = []
            start = time.perf_counter()
            runner.run()
            wall = time.perf_counter() - start
    session = load_session(campaign.session)
    result = identify_session(session)
    verdict = fit_verdict(result)
    settles = session.of_type(SettleRecord)
    errors = np.array(runner.errors_mm)
    return {"wall": wall, "settle": sum(r.waited_s for r in settles) / speed,
            "ended": {e: sum(1 for r in settles if r.ended == e)
                      for e in ("stable", "bound", "time", "not moved")},
            "offsets": result.values, "std": result.std, "verdict": verdict,
            "miss": np.abs(result.values - truth) / result.std,
            "error_rms": float(np.sqrt(np.mean((errors - errors.mean()) ** 2)))}


def line(name: str, r: dict) -> str:
    v = r["verdict"]
    offsets = " ".join(f"{x:+.4f}+-{s:.4f}" for x, s in zip(r["offsets"], r["std"], strict=True))
    denominator = f", {v.noise_dof:.0f}" if v.noise_dof is not None else ""
    return (f"   {name:<6} {r['wall']:5.1f} s (settle {r['settle']:4.1f} s) offsets {offsets}; "
            f"{v.test} {v.statistic:.2f} ({v.dof}{denominator}) p = {v.overall_p:.3f}; "
            f"error rms {r['error_rms'] * 1e3:.3f} um = {r['error_rms'] / U_MM:.2f} u; "
            f"misses the truth by {r['miss'].max():.2f} std at most")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n", 1)[0])
    parser.add_argument("--seeds", default="1,2,3,4,5")
    parser.add_argument("--speed", type=float, default=1.0)
    args = parser.parse_args()
    seeds = [int(s) for s in args.seeds.split(",")]
    folder = Path(tempfile.mkdtemp(prefix="ogacq-settle-sweep-"))
    (folder / "machine.toml").write_text(MACHINE)
    print(f"1 um gauges (noise {NOISE_MM * 1e3:g} um, u = {U_MM * 1e3:.2f} um), papers' "
          f"campaign, x{args.speed:g}, settle_s 1.0, window 0.1 s:")
    shifts, p_fixed, p_stable, walls, misses = [], [], [], [], []
    for seed in seeds:
        fixed = run(folder, seed, "fixed", args.speed)
        stable = run(folder, seed, "stable", args.speed)
        shift = np.abs(stable["offsets"] - fixed["offsets"]) / np.hypot(fixed["std"],
                                                                         stable["std"])
        shifts.append(float(np.max(shift)))
        p_fixed.append(fixed["verdict"].overall_p)
        p_stable.append(stable["verdict"].overall_p)
        walls.append((fixed["wall"], stable["wall"]))
        misses.append((fixed["miss"].max(), stable["miss"].max()))
        print(f" seed {seed}:")
        print(line("fixed", fixed))
        print(line("stable", stable) + f"; settles {stable['ended']}")
        print(f"   stable vs fixed: offsets differ by {shift.max():.2f} std at most, "
              f"{1 - stable['wall'] / fixed['wall']:.1%} shorter", flush=True)
    print(f"over {len(seeds)} seeds: largest offset shift {max(shifts):.2f} std of the "
          f"difference; largest miss of the truth fixed {max(m[0] for m in misses):.2f}, "
          f"stable {max(m[1] for m in misses):.2f} std; lack-of-fit p "
          f"fixed {' '.join(f'{p:.3f}' for p in p_fixed)}, stable "
          f"{' '.join(f'{p:.3f}' for p in p_stable)} (stable lower in "
          f"{sum(s < f for s, f in zip(p_stable, p_fixed, strict=True))} of {len(seeds)}); "
          f"wall fixed {np.mean([w[0] for w in walls]):.1f} s, stable "
          f"{np.mean([w[1] for w in walls]):.1f} s on average")


if __name__ == "__main__":
    sys.exit(main())
