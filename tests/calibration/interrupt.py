"""``ogacq ARGS`` killed (SIGKILL) or interrupted (Ctrl-C) at one window between a
write to the machine and its audit record, for the resume tests and
bench/bench_calibrate_kills.py:

    python -m tests.calibration.interrupt WINDOW [--ctrl-c] [--flip] -- ARGS...

WINDOW (each in a write, or in a restore with ``restore-`` before it):

- ``offsets-sent``: the new offsets just sent to the controller, before the read-back,
  the re-homing and the ``done`` record;
- ``offsets-half``: x and y of the new offsets written, z not yet;
- ``offsets-done``: read back and re-homed, the ``done`` record about to be written;
- ``maps-done``: the maps file replaced, the ``done`` record about to be written;
- ``none``: no interruption.

``--second``: at the window of the second such write (a calibration's second round).
``--flip``: the maps of ``ogacq calibrate`` turned in sign, and its offsets put
turned too, so that its validation is worse and it restores (as
tests/calibration/test_calibrate_e2e.py does with the maps). ``--flip-first``: the
maps of the first compensation this process computes turned in sign (the first
round's, not the second round's: tests/calibration/test_second_round.py).
"""

from __future__ import annotations

import dataclasses
import math
import os
import signal
import sys
from typing import Any

from ogacq_drivers.axes.controller import AxisController
from ogacq.calibration import procedure
from ogacq.cli.app import main
from ogacq.model.axis_map import AxisMap
from ogacq.writeback.audit import AuditLog

SKEW_MM = 0.3
WINDOWS = ("offsets-sent", "offsets-half", "offsets-done", "maps-done")


def flipped(comp: Any) -> Any:
    """The compensation with its maps' sign turned: applied, it doubles the error."""
    maps = {a: AxisMap(m.axis, m.positions_mm, tuple(-v for v in m.forward_mm),
                       tuple(-v for v in m.reverse_mm), m.u_forward_mm, m.u_reverse_mm,
                       m.reference_mm, "sign turned on purpose")
            for a, m in comp.maps.items()}
    return dataclasses.replace(comp, maps=maps)


def flipped_first(made: Any) -> Any:
    """``made`` (a compensation_of) whose first result has its maps turned in sign."""
    calls = []

    def first_wrong(*args: Any, **kwargs: Any) -> Any:
        calls.append(1)
        comp = made(*args, **kwargs)
        return flipped(comp) if len(calls) == 1 else comp
    return first_wrong


def skewed(evidence: Any) -> Any:
    """The evidence with each identified offset turned in sign and 0.3 mm further:
    written, each axis is left twice as far off as it was found, and 0.3 mm more."""
    return dataclasses.replace(evidence, identified_mm={
        a: -v - math.copysign(SKEW_MM, v) for a, v in evidence.identified_mm.items()})


def arm(window: str, ctrl_c: bool, nth: int = 1) -> None:
    """Patch the write path to stop at ``window`` (``restore-WINDOW``: in a restore) of
    the ``nth`` such write (2: a calibration's second round)."""
    action, _, where = window.partition("-") if window.startswith("restore-") \
        else ("write", "", window)
    doing: dict[str, str] = {}
    reached = [0]

    def stop() -> None:
        reached[0] += 1
        if reached[0] < nth:
            return
        if ctrl_c:
            raise KeyboardInterrupt
        os.kill(os.getpid(), signal.SIGKILL)

    record, record_maps = AuditLog.record, AuditLog.record_maps

    def record_hook(self: AuditLog, stage: str, **fields: Any) -> None:
        if stage == "intent":
            doing["offsets"] = str(fields.get("action"))
        if stage == "done" and where == "offsets-done" and fields.get("action") == action:
            stop()
        record(self, stage, **fields)

    def record_maps_hook(self: AuditLog, stage: str, **fields: Any) -> None:
        if stage == "done" and where == "maps-done" and fields.get("action") == action:
            stop()
        record_maps(self, stage, **fields)

    write_offsets = AxisController.write_offsets

    def write_hook(self: AxisController, offsets_mm: Any, *, force: bool = False) -> Any:
        if doing.get("offsets") != action:
            return write_offsets(self, offsets_mm, force=force)
        if where == "offsets-half":
            write_offsets(self, {**self.read_offsets(), "x": offsets_mm["x"],
                                 "y": offsets_mm["y"]}, force=force)
            stop()
        change = write_offsets(self, offsets_mm, force=force)
        if where == "offsets-sent":
            stop()
        return change

    AuditLog.record = record_hook  # type: ignore[method-assign]
    AuditLog.record_maps = record_maps_hook  # type: ignore[method-assign]
    AxisController.write_offsets = write_hook  # type: ignore[method-assign]


def run(argv: list[str]) -> int:
    split = argv.index("--")
    options, args = argv[:split], argv[split + 1:]
    window = options[0]
    if window != "none":
        arm(window, "--ctrl-c" in options, 2 if "--second" in options else 1)
    if "--flip" in options:
        made, identified = procedure.compensation_of, procedure.evidence_for
        procedure.compensation_of = lambda *a, **k: flipped(made(*a, **k))  # type: ignore[assignment]
        procedure.evidence_for = lambda *a, **k: skewed(identified(*a, **k))  # type: ignore[assignment]
    if "--flip-first" in options:
        procedure.compensation_of = flipped_first(procedure.compensation_of)  # type: ignore[assignment]
    return main(args)


if __name__ == "__main__":
    sys.exit(run(sys.argv[1:]))
