"""The one runner that executes a campaign plan against a station.

It records every reading the moment it is taken, skips what a session already
holds (resume), reproduces the approach side of the posture it resumes at,
retries device faults within bounds and otherwise stops safely: axes stopped,
the stop recorded, the session resumable. It never prints: progress goes to an
observer callback that the command line renders.

After a drive was lost and the axes homed again (the station says so), and on a
resume, the readings on file are only as good as the reference they were taken
with: the runner goes back to the posture of the last reading on file, from the
same side, and reads its gauges again (the check posture). Within the noise, the
campaign goes on; otherwise it stops, saying that the readings taken before the
loss are not to be trusted.
"""

from __future__ import annotations

import contextlib
import dataclasses
import itertools
import time
from collections.abc import Callable, Iterable, Iterator, Sequence
from dataclasses import dataclass

import numpy as np

from ogacq_drivers.errors import DeviceFault, DeviceTimeout, DriverError, LinkError
from ogacq.compensation.applied import TargetCorrection
from ogacq.errors import OgacqError, StorageError
from ogacq.model.gauges import Gauge
from ogacq.model.machine import MachineSpec
from ogacq.protocol.plan import (
    Move,
    ProtocolConfig,
    Read,
    SetGauges,
    SettleRule,
    campaign_steps,
)
from ogacq.protocol.station import GaugeValue, SettledGauge, Station
from ogacq.session.records import (
    EndRecord,
    FaultRecord,
    GaugesSetRecord,
    MoveRecord,
    ReadingRecord,
    ReferenceRecord,
    SettleRecord,
)
from ogacq.session.store import SessionWriter


class CampaignStopped(OgacqError):
    """The campaign stopped before the end; the session says why and can be resumed.
    Not a DriverError: the runner retries those, and an operator's stop is final."""

    def __init__(self, reason: str, status: str = "stopped") -> None:
        self.reason = reason
        self.status = status
        self.exit_code = 130 if status == "interrupted" else 3
        super().__init__(reason)


def run_to_end(body: Callable[[], None], station: Station, writer: SessionWriter,
               readings: Callable[[], int]) -> None:
    """``body`` run to the end and the session's end recorded; on a stop (the operator,
    a device, a full disk) the axes stopped, why recorded, and CampaignStopped raised."""
    def stop(status: str, reason: str) -> None:
        try:
            station.stop_axes()
            stopped = True
        except DriverError:
            stopped = False
        # The disk that stopped the run may refuse this too: the session then ends
        # like one whose process died, and resumes the same way.
        with contextlib.suppress(StorageError):
            writer.write(EndRecord(status=status, reason=reason, axes_stopped=stopped,
                                   readings=readings()))

    try:
        body()
        writer.write(EndRecord(status="complete", readings=readings()))
    except CampaignStopped as stopped:
        stop(stopped.status, stopped.reason)
        raise
    except KeyboardInterrupt:
        stop("interrupted", "interrupted by the operator (Ctrl-C)")
        raise CampaignStopped("interrupted by the operator", "interrupted") from None
    except DriverError as exc:
        stop("stopped", str(exc))
        raise CampaignStopped(str(exc)) from exc
    except StorageError as exc:  # disk full or read-only: what is on file stays valid
        stop("stopped", str(exc))
        raise CampaignStopped(str(exc)) from None


@dataclass(frozen=True)
class Progress:
    done: int
    total: int
    message: str


Observer = Callable[[Progress], None]
GaugeSetter = Callable[[SetGauges], None]


GAUGE_ATTEMPTS = 3
MOVE_ATTEMPTS = 2
BACKOFF_S = 0.05  # before a gauge's next attempt, times the attempts made


class CampaignRunner:
    def __init__(self, station: Station, writer: SessionWriter, config: ProtocolConfig,
                 machine: MachineSpec, *, recorded: set[tuple[str, str]] | None = None,
                 observer: Observer | None = None, set_gauges: GaugeSetter | None = None,
                 previous: Sequence[ReadingRecord] = (), check_first: bool = False,
                 correction: TargetCorrection | None = None) -> None:
        """``previous``: the readings a resumed session holds, in order; with
        ``check_first`` (a resume: the axes were homed anew) the posture of the last of
        them is checked before anything else. ``correction``: the error maps ogacq
        applies itself (every target corrected, the plan's recorded)."""
        self.station = station
        self.writer = writer
        self.config = config
        self.machine = machine
        self.recorded = set(recorded or ())
        self.observer = observer or (lambda progress: None)
        self.set_gauges = set_gauges
        self.correction = correction
        # the display step is the machine file's: what a still gauge may round by
        self._settle_rule = dataclasses.replace(config.settle_rule,
                                                display_step_mm=machine.gauge_resolution_mm)
        self._steps = list(campaign_steps(config, machine))
        self._commanded_q: tuple[float, float, float] | None = None
        self._planned_q: tuple[float, float, float] | None = None
        self._total = sum(len(s.gauges) for s in self._steps if isinstance(s, Read))
        # Each step's readings on file (gauge -> value) and the step read last: the
        # check posture after a loss reads it again.
        self._values: dict[str, dict[str, float]] = {}
        self._last_step: str | None = None
        for reading in previous:
            self._values.setdefault(reading.step, {})[reading.gauge.key] = reading.reading_mm
            self._last_step = reading.step
        self._check_first = check_first
        self._mounted_leg: str | None = None  # moved indicators: where they are now

    @property
    def total_readings(self) -> int:
        return self._total

    def run(self) -> None:
        """Run to the end, or raise CampaignStopped after recording why."""
        run_to_end(self._run, self.station, self.writer, lambda: len(self.recorded))

    def _run(self) -> None:
        if self._check_first:
            self._check_posture("resume")
        pending: list[Move] = []
        came_from: Move | None = None  # the plan's last posture before ``pending``
        moved = False
        disturbed = True  # something moved (or a hand set the gauges) since the last read
        for step in self._steps:
            if isinstance(step, Move):
                pending.append(step)
                continue
            if not self._done(step):
                moves = pending
                if not moved and came_from is not None:
                    # Resuming: arrive from the posture the plan came from, so that
                    # each joint approaches from the same side as it would have.
                    moves = [came_from, *pending]
                disturbed = self._execute_moves(moves) or disturbed
                moved = True
                if isinstance(step, SetGauges):
                    self._set_gauges(step)
                    # a hand on the gauges shakes them; pre-mounted ones nobody touched
                    disturbed = disturbed or self.set_gauges is not None
                else:
                    self._read_step(step, settle=disturbed)
                    disturbed = False
            came_from = next((m for m in reversed(pending) if m.purpose == "posture"),
                             came_from)
            pending = []

    def _done(self, step: SetGauges | Read) -> bool:
        if isinstance(step, SetGauges):  # measuring this leg began: its gauges are set
            return any(Gauge.parse(g).leg == step.leg for _, g in self.recorded)
        return all((step.step, g) in self.recorded for g in step.gauges)

    def _set_gauges(self, step: SetGauges) -> None:
        if self.set_gauges is not None:
            self.set_gauges(step)
            self._mounted_leg = step.leg
        self.writer.write(GaugesSetRecord(leg=step.leg, gauges=step.gauges))
        self.observer(Progress(len(self.recorded), self._total,
                               f"gauges set on the {step.leg} leg"))

    def _execute_moves(self, moves: list[Move]) -> bool:
        """Command the moves; True when the axes moved (not when already there). A
        failed move is retried after the station recovered the axes; where they were
        homed again, the posture of the last reading is checked first and the moves
        start over from it, so that each joint still approaches from its side."""
        moved = False
        index, attempt = 0, 1
        while index < len(moves):
            move = moves[index]
            if self._planned_q is not None and np.allclose(move.q_mm, self._planned_q,
                                                           atol=1e-9):
                index += 1
                continue  # already there (Zero -> Zero between cycles): nothing to command
            try:
                self._command(move.q_mm, move.purpose)
                moved = True
            except (DeviceFault, DeviceTimeout, LinkError) as exc:  # recover_axes reconnects
                self.writer.write(FaultRecord(during="move", attempt=attempt,
                                              error=type(exc).__name__, message=str(exc),
                                              q_mm=move.q_mm))
                if attempt == MOVE_ATTEMPTS or not self.station.recover_axes():
                    raise CampaignStopped(f"move to q = {_fmt(move.q_mm)} mm failed: "
                                          f"{exc}") from exc
                attempt += 1
                # where a stop left the axes is not where the plan was: command again,
                # from a side the maps do not know
                self._commanded_q = self._planned_q = None
                if self.correction is not None:
                    self.correction.forget()
                if self.station.take_check_request():
                    self._check_posture("loss")
                    index = 0
                continue
            index, attempt = index + 1, 1
        return moved

    def _command(self, q_mm: tuple[float, float, float], purpose: str) -> None:
        """Command the joints to land at ``q_mm`` and record the move: where they are
        meant to be now, and the targets sent when error maps correct them (None when
        none do)."""
        sent: tuple[float, float, float] | None = None
        if self.correction is None:
            self._commanded_q = self.station.move(q_mm, self.config.move_timeout_s)
        else:
            sent = self.station.move(self.correction.command(q_mm), self.config.move_timeout_s)
            self._commanded_q = self.correction.nominal(q_mm, sent)
        self._planned_q = q_mm
        self.writer.write(MoveRecord(q_mm=self._commanded_q, purpose=purpose,
                                     commanded_mm=sent))

    # ------------------------------------------------------------ check posture

    def check_tolerance_mm(self) -> float:
        """How far a gauge may read from its reading on file at the check posture: twice
        the spread of a stable reading and the display step (no source: the noise a
        reading is taken within, on either side)."""
        return 2.0 * (self.config.stability.tolerance_mm + self.machine.gauge_resolution_mm)

    def _check_posture(self, cause: str) -> None:
        """Back to the posture of the last reading on file, approached from the same
        side, and its gauges read again: the re-homed machine must read the same."""
        step = next((s for s in self._steps if isinstance(s, Read)
                     and s.step == self._last_step), None)
        if step is None:
            self.writer.write(ReferenceRecord(event="not_checked", cause=cause,
                                              message="no reading on file yet"))
            return
        if self.set_gauges is not None and self._mounted_leg != step.leg:
            self.writer.write(ReferenceRecord(
                event="not_checked", cause=cause, step=step.step,
                message=f"the indicators were moved off the {step.leg} leg since its last "
                        "reading (or are set anew): the check posture cannot be read"))
            return
        recorded = self._values[step.step]
        for move in self._approach_to(step):
            self._command(move.q_mm, "check")
        now = self._read_again(step, list(recorded))
        tolerance = self.check_tolerance_mm()
        differences = {g: round(now[g] - recorded[g], 6) for g in recorded}
        worst = max(differences, key=lambda g: abs(differences[g]))
        passed = abs(differences[worst]) <= tolerance + 1e-9
        self.writer.write(ReferenceRecord(
            event="checked" if passed else "check_failed", cause=cause, step=step.step,
            differences_mm=differences, tolerance_mm=round(tolerance, 6)))
        self.observer(Progress(len(self.recorded), self._total,
                               f"check posture {step.step}: "
                               + ("as before" if passed else "differs")))
        if not passed:
            raise CampaignStopped(
                f"after the axes were homed again, the check posture {step.step} reads "
                f"{differences[worst]:+.4f} mm off at gauge {worst} (within "
                f"{tolerance:.4f} mm expected): the machine's reference moved, so the "
                "readings taken before are not to be trusted; start a new campaign")

    def _approach_to(self, step: Read) -> list[Move]:
        """The moves the plan makes to reach ``step``: the posture it came from, then
        its approach moves and the posture itself."""
        at = self._steps.index(step)
        moves: list[Move] = []
        k = at - 1
        while k >= 0 and not isinstance(earlier := self._steps[k], Read):
            if isinstance(earlier, Move):
                moves.insert(0, earlier)
            k -= 1
        came_from = next((m for m in reversed(self._steps[:k + 1])
                          if isinstance(m, Move) and m.purpose == "posture"), None)
        return ([came_from] if came_from is not None else []) + moves

    def _read_again(self, step: Read, gauges: list[str]) -> dict[str, float]:
        """The gauges' values now, settled as a reading is (nothing recorded)."""
        rule = self._settle_rule
        out: dict[str, float] = {}
        if rule.kind == "stable":
            for gauge, settled in self.station.read_settled(step, gauges, rule).items():
                if isinstance(settled, SettledGauge) and settled.value is not None:
                    out[gauge] = settled.value.value_mm
        else:
            self.station.settle(rule.bound_s)
        for gauge, result in self._read_now(step, [g for g in gauges if g not in out]):
            if isinstance(result, DriverError):
                raise result
            out[gauge] = result.value_mm
        return out

    def _read_step(self, step: Read, *, settle: bool) -> None:
        """Settle (when something moved) and read the step's gauges not yet on file."""
        gauges = [g for g in step.gauges if (step.step, g) not in self.recorded]
        rule = self._settle_rule
        first: dict[str, GaugeValue | DriverError] = {}
        if rule.kind == "stable":
            # where nothing moved nothing rings, but the rule reads its two windows all
            # the same, so that every reading is the mean of as many values (a 3-value
            # reading beside 12-value ones weighed alike made a scan "NOT within the
            # noise")
            first = self._settle_stable(step, gauges, rule, moved=settle)
        elif not settle:
            self.writer.write(SettleRecord(step=step.step, rule="none", ended="not moved",
                                           waited_s=0.0))
        else:
            self.station.settle(rule.bound_s)
            self.writer.write(SettleRecord(step=step.step, rule="fixed", ended="time",
                                           waited_s=rule.bound_s))
        self._read_gauges(step, gauges, first)

    def _settle_stable(self, step: Read, gauges: list[str], rule: SettleRule, *,
                       moved: bool = True) -> dict[str, GaugeValue | DriverError]:
        """Read from in position until the gauges are at rest; their values, or the
        errors that count as each gauge's first attempt."""
        read = self._read_until_rest(step, gauges, rule)
        settled = {g: r for g, r in read.outcome.items() if isinstance(r, SettledGauge)}
        unsettled = tuple(g for g, r in settled.items() if r.value is None)
        u_mm = {g: round(r.u_mm, 7) for g, r in settled.items() if r.u_mm is not None}
        ended = "bound" if read.at_bound else "stable" if moved else "not moved"
        self.writer.write(SettleRecord(
            step=step.step, rule="stable", ended=ended, waited_s=round(read.waited_s, 4),
            values=read.values, unsettled=unsettled, reference=read.reference,
            u_mm=u_mm or None))
        first: dict[str, GaugeValue | DriverError] = {}
        for gauge, result in read.outcome.items():
            if isinstance(result, DriverError):
                first[gauge] = result
            elif result.value is not None:
                first[gauge] = result.value
            elif gauge in read.read_on and result.unjudged is not None and \
                    (result.unjudged.averaged or 0) >= self.config.stability.readings:
                # two bounds and still not at rest by the rule: its last two windows'
                # mean, as many values as a settled reading, where the stability rule
                # read three (one such, weighed as a 12-value reading, lay at chi2 23)
                first[gauge] = result.unjudged
        return first

    def _read_until_rest(self, step: Read, gauges: list[str], rule: SettleRule,
                         ) -> _UntilRest:
        """The gauges read until at rest (``_UntilRest``). A gauge that reached the bound
        with a rest to be judged against (measured there, or before) is read on at
        once, for at most another bound: its reading then is the mean of two windows at
        rest as every other is, not of the stability rule's few (at 25x, one settle in 20 reached
        the bound by chance, and its 3-value reading, weighed as a 12-value one, made a
        separating scan "NOT within the noise")."""
        outcome = dict(self.station.read_settled(step, gauges, rule))
        settled = {g: r for g, r in outcome.items() if isinstance(r, SettledGauge)}
        at_bound = tuple(g for g, r in settled.items() if r.value is None)
        values = {g: r.values for g, r in settled.items()}
        waited = _longest(settled.values())
        judged = tuple(g for g in at_bound if settled[g].u_mm is not None)
        if judged:
            again = self.station.read_settled(step, list(judged), rule)
            outcome.update(again)
            read_on = {g: r for g, r in again.items() if isinstance(r, SettledGauge)}
            values.update({g: values[g] + r.values for g, r in read_on.items()})
            waited += _longest(read_on.values())
        reference = tuple(g for g in at_bound if settled[g].measured_rest)
        return _UntilRest(outcome, at_bound, reference, judged, values, waited)

    def _read_gauges(self, step: Read, gauges: Sequence[str],
                     first: dict[str, GaugeValue | DriverError]) -> None:
        """Read ``gauges`` at once, retrying each failed one within bounds; each value is
        recorded as it comes. ``first``: values (or errors) the settle already took."""
        missing = list(gauges)
        for attempt in range(1, GAUGE_ATTEMPTS + 1):
            given = [(g, first[g]) for g in missing if g in first] if attempt == 1 else []
            ask = [g for g in missing if g not in dict(given)]
            failed: dict[str, DriverError] = {}
            for gauge, result in itertools.chain(given, self._read_now(step, ask)):
                if isinstance(result, DriverError):  # silent, 911, garbled, unplugged
                    self.writer.write(FaultRecord(during="read", step=step.step, gauge=gauge,
                                                  attempt=attempt, error=type(result).__name__,
                                                  message=str(result)))
                    failed[gauge] = result
                else:  # kept at once, whatever happens to the others
                    self._record(step, gauge, result)
            if not failed:
                return
            missing = [g for g in missing if g in failed]
            if attempt == GAUGE_ATTEMPTS:
                error = failed[missing[0]]
                raise CampaignStopped(f"gauge {missing[0]} at {step.step}: {error} "
                                      f"({attempt} attempts)") from error
            time.sleep(BACKOFF_S * attempt)

    def _read_now(self, step: Read, gauges: list[str],
                  ) -> Iterator[tuple[str, GaugeValue | DriverError]]:
        """Each gauge's value or error, as each comes (a station reading them at once
        gives them together; gauges read by eye come one by one)."""
        if gauges:
            yield from self.station.read_gauges(step, gauges, self.config.stability)

    def _record(self, step: Read, gauge: str, value: GaugeValue) -> None:
        self.writer.write(ReadingRecord(
            step=step.step, gauge=Gauge.parse(gauge), cycle=step.cycle, posture=step.posture,
            t_s=round(self.station.campaign_time_s(), 3),
            q_mm=self._commanded_q or step.q_mm, tcp_mm=step.tcp_mm, approach=step.approach,
            reading_mm=value.value_mm, raw=value.raw, source=value.where,
            averaged=value.averaged, averaged_sd_mm=value.averaged_sd_mm))
        self.recorded.add((step.step, gauge))
        self._values.setdefault(step.step, {})[gauge] = value.value_mm
        self._last_step = step.step
        self.observer(Progress(len(self.recorded), self._total,
                               f"{step.step} {gauge} = {value.value_mm:.4f} mm"))


@dataclasses.dataclass(frozen=True)
class _UntilRest:
    """The gauges of a step read until at rest: each one's settle (or error), those
    that reached the bound, those of them that measured their rest there, those read
    on after it, the values each read and the machine seconds it took."""

    outcome: dict[str, SettledGauge | DriverError]
    at_bound: tuple[str, ...]
    reference: tuple[str, ...]
    read_on: tuple[str, ...]
    values: dict[str, int]
    waited_s: float


def _longest(settled: Iterable[SettledGauge]) -> float:
    """The machine seconds a settle took: its slowest gauge's."""
    return max((r.waited_s for r in settled), default=0.0)


def _fmt(q: tuple[float, float, float]) -> str:
    return "(" + ", ".join(f"{v:.3f}" for v in q) + ")"
