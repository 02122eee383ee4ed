"""A real ``ogacq sim`` process per test that needs one, campaign files pointing at
it, the ``ogacq`` command with stdin, and synthetic sessions for the refusals."""

from __future__ import annotations

import contextlib
import io
import json
import os
import selectors
import signal
import subprocess
import sys
from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ogacq.campaign.campaign_file import read_campaign
from ogacq.campaign.station import open_controller
from ogacq.cli.app import main
from ogacq.model.gauges import Gauge
from ogacq.model.machine import MachineSpec
from ogacq.model.parameters import AXES, vector
from ogacq.protocol.plan import ProtocolConfig, planned_layout
from ogacq.session.records import EndRecord, ReadingRecord
from ogacq.session.store import SessionWriter
from tests.campaign.conftest import MACHINE
from tests.interrupts import sigint_as_at_a_terminal

SPEED = 50.0  # simulated time runs this much faster
# The external simulator's clock is its own: the campaign settles in real seconds,
# so 0.01 s here is the 0.5 s of machine time the other campaign tests use.
SETTLE_S = 0.01
# Two agreeing readings make a stable one (the fault tests' rule): the noise is 1 um
FAST_STABILITY = "\n[stability]\nreadings = 2\ntolerance_mm = 0.003\ntimeout_s = 1.0\n"


@contextlib.contextmanager
def simulator(folder: Path, profile: str, seed: int, effects: str | None = None,
              ) -> Iterator[dict]:
    """``ogacq sim`` in its own process (its controller keeps written offsets while it
    lives), hiding ``effects`` (TOML) when given; yields where it serves; stopped by
    its process id."""
    folder.mkdir(parents=True, exist_ok=True)
    machine = folder / "machine.toml"
    machine.write_text(MACHINE)
    hidden: list[str] = []
    if effects is not None:
        (folder / "effects.toml").write_text(effects)
        hidden = ["--effects", str(folder / "effects.toml")]
    log = (folder / f"sim-{profile}.log").open("w")
    with sigint_as_at_a_terminal():  # stopped by Ctrl-C below
        proc = subprocess.Popen(
            [sys.executable, "-m", "ogacq", "sim", "--profile", profile, "--seed", str(seed),
             "--speed", str(SPEED), "--machine", str(machine), "--json", *hidden],
            stdout=subprocess.PIPE, stderr=log, text=True)
    try:
        selector = selectors.DefaultSelector()
        selector.register(proc.stdout, selectors.EVENT_READ)
        if not selector.select(timeout=30):
            raise RuntimeError(f"ogacq sim did not start; see {log.name}")
        info = json.loads(proc.stdout.readline())
        yield info
    finally:
        proc.send_signal(signal.SIGINT)
        try:
            proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()
        log.close()


def sim_campaign(folder: Path, info: Mapping, *, name: str, offsets_file: str | None = None,
                 extra: str = FAST_STABILITY, maps_file: str | None = None) -> Path:
    """A campaign file talking to a running ``ogacq sim`` through [controller] and
    [[gauges]], the way one talks to hardware; its session is ``NAME.jsonl``."""
    m = info["modbus"]
    if m["transport"] == "tcp":
        controller = f'port = "{m["host"]}:{m["port"]}"\n'
    else:
        controller = f'port = "{m["port"]}"\nbaudrate = {m["baudrate"]}\n'
    if offsets_file:
        controller += f'offsets_file = "{offsets_file}"\n'
    if maps_file:
        controller += f'maps_file = "{maps_file}"\n'
    gauges = "".join(f'\n[[gauges]]\ngauge = "{key}"\nprotocol = "{g["protocol"]}"\n'
                     f'port = "{g["port"]}"\n' for key, g in info["gauges"].items())
    path = folder / f"{name}.toml"
    path.write_text(f'machine = "machine.toml"\nsession = "{name}.jsonl"\n\n[controller]\n'
                    f'profile = "{m["profile"]}"\n{controller}\n[protocol]\n'
                    f"settle_s = {SETTLE_S}\n{extra}{gauges}")
    return path


def emulated_campaign(folder: Path, port: int | None) -> Path:
    """A campaign file whose controller is a drive emulator serving on ``port`` (its
    gauges named, never opened by the write-backs)."""
    gauges = "".join(f'\n[[gauges]]\ngauge = "{k}"\nprotocol = "mitutoyo-01a"\n'
                     f'port = "/dev/ttyUSB{n}"\n'
                     for n, k in enumerate(("y_x", "z_x", "x_y", "z_y", "x_z", "y_z")))
    (folder / "machine.toml").write_text("leg_length_mm = 310.25\nrho_min_mm = -100.0\n"
                                         "rho_max_mm = 60.0\ngauge_resolution_mm = 0.001\n")
    campaign = folder / "campaign.toml"
    campaign.write_text(f'machine = "machine.toml"\n[controller]\nprofile = "cia402"\n'
                        f'port = "127.0.0.1:{port}"\n' + gauges)
    return campaign


def ogacq(*args: str | Path, stdin: str = "", timeout: float = 120,
          ) -> subprocess.CompletedProcess:
    env = {**os.environ, "COLUMNS": "160"}  # keep rich from wrapping the reasons
    return subprocess.run([sys.executable, "-m", "ogacq", *map(str, args)], input=stdin,
                          capture_output=True, text=True, timeout=timeout, env=env)


@dataclass
class Ran:
    returncode: int
    stdout: str
    stderr: str


def ogacq_here(capsys, monkeypatch, *args: str | Path, stdin: str = "") -> Ran:
    """``ogacq ARGS`` through the same ``main`` in this process, with ``stdin`` as the
    operator's answers: what the subprocess does, without a second of start-up."""
    monkeypatch.setattr(sys, "stdin", io.StringIO(stdin))
    capsys.readouterr()
    code = main([str(a) for a in args])
    captured = capsys.readouterr()
    return Ran(code, captured.out, captured.err)


def controller_offsets(campaign_path: Path) -> dict[str, float]:
    """Read the controller (or its software table) back, as the tool would."""
    spec = read_campaign(campaign_path).controller
    with open_controller(spec) as controller:
        return controller.read_offsets()


def synthetic_session(path: Path, campaign_path: Path, *, offsets_mm: Mapping[str, float],
                      effects: Mapping[str, float] | None = None, legs=(0, 1, 2),
                      postures=("zero", "max", "min", "zero"), noise_mm: float = 0.001,
                      in_force_mm: Mapping[str, float] | None = None, profile: str = "cia402",
                      seed: int = 0, header_extra: Mapping | None = None,
                      slip: tuple[int, float] | None = None) -> Path:
    """A finished campaign's session, made with the exact model instead of a machine:
    what a real campaign records, in a fraction of a second. ``slip``: (row, mm) one
    reading off by that much (misread, or the gauge knocked and set back)."""
    machine = MachineSpec(310.25, -100.0, 60.0, gauge_resolution_mm=0.001)
    lay = planned_layout(ProtocolConfig(legs=tuple(AXES[i] for i in legs),
                                        postures=tuple(postures)), machine)
    from ogacq.identify.observations import readings_observations

    truth = {f"joint_offset.{a}": v for a, v in offsets_mm.items()} | dict(effects or {})
    clean = readings_observations(machine, lay, np.zeros(len(lay))).predict(
        vector(truth)[None])[0]
    rng = np.random.default_rng(seed)
    values = clean + rng.uniform(3.0, 9.0, lay.n_gauges)[lay.gauge] \
        + rng.normal(0.0, noise_mm, len(lay))
    values = np.round(values / 0.001) * 0.001
    if slip is not None:
        values[slip[0]] += slip[1]
    in_force = dict(in_force_mm) if in_force_mm is not None else dict.fromkeys(AXES, 0.0)
    header = {"machine": {"leg_length_mm": 310.25, "rho_min_mm": -100.0, "rho_max_mm": 60.0,
                          "gauge_resolution_mm": 0.001},
              "campaign_file": str(campaign_path.resolve()),
              "station": {"controller": {"profile": profile, "port": "synthetic",
                                         "offsets_mm": in_force}},
              "plan": None, **(header_extra or {})}
    write_layout_session(path, header, lay, values, "synthetic")
    return path


def write_layout_session(path: Path, header: Mapping, lay, values, step: str) -> None:
    """A finished session of the readings ``values`` taken as the layout ``lay`` says
    (each reading its own step, ``step/1``, ``step/2``, ...)."""
    with SessionWriter.create(path, dict(header)) as writer:
        for k in range(len(lay)):
            writer.write(ReadingRecord(
                step=f"{step}/{k + 1}", gauge=Gauge.at(lay.gauge_axis[k], lay.leg[k]),
                cycle=int(lay.cycle[k]), posture=lay.posture[k], t_s=float(lay.t_s[k]),
                q_mm=tuple(lay.q_mm[k].tolist()), tcp_mm=tuple(lay.tcp_mm[k].tolist()),
                approach=tuple(lay.approach[k].tolist()), reading_mm=float(values[k])))
        writer.write(EndRecord(status="complete"))
