"""The end of every campaign (run, resume, demo, the wizard): the verdict, the
record's id (independent of when ``ogacq report`` issues it, so said before) and the
next command, and the record the history stores, built once."""

from __future__ import annotations

import logging
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ogacq.cli.verdict_text import one_line
from ogacq.diagnose.outliers import described_outliers
from ogacq.identify.consistency import Verdict, fit_verdict
from ogacq.identify.fit import FitResult
from ogacq.model.gauges import AXES
from ogacq.record.calibration_record import CalibrationRecord
from ogacq.session.series import next_session
from ogacq.session.store import LoadedSession, load_session

log = logging.getLogger("ogacq")


@dataclass(frozen=True)
class NextStep:
    command: str  # what to type ("" for advice without a command)
    why: str


@dataclass(frozen=True)
class CampaignEnd:
    session: Path
    record: Mapping[str, Any]  # the ogacq-record/1 document of the session
    verdict: Verdict
    steps: tuple[NextStep, ...]
    report: Path | None = None  # the page written already (the demo's)
    # a validation after a write-back from a diagnosis: its fit with that diagnosis's
    # effects carried over, in words (the joint offsets alone are biased by them)
    carried: str | None = None

    @property
    def record_id(self) -> str:
        return str(CalibrationRecord.from_json(self.record).id)

    @property
    def built(self) -> Mapping[str, Any] | None:
        """The record whole (what the history stores); None when it could not be built
        (the history then builds it, and warns)."""
        return self.record if "format" in self.record else None

    def lines(self) -> list[str]:
        """Plain text (escape it before rich sees it)."""
        issued = (f"issued as {self.report.with_name('record.json')}" if self.report
                  else "`ogacq report` issues it: report.html and record.json")
        out = [f"verdict: {one_line(self.verdict)}", f"record: {self.record_id} ({issued})"]
        if self.carried is not None:
            out.insert(1, self.carried)
        return out + step_lines(self.steps)


def step_lines(steps: Sequence[NextStep]) -> list[str]:
    """The next steps as every command ends with them: ``next: COMMAND   (why)``, the
    others below it (plain text)."""
    return [("next: " if k == 0 else "      ")
            + (f"{step.command}   ({step.why})" if step.command else step.why)
            for k, step in enumerate(steps)]


def campaign_end(session_path: Path, fit: FitResult, *, simulated: bool,
                 report: Path | None = None, rehearsal_writeback: bool = False,
                 ) -> CampaignEnd:
    """The end of the campaign recorded in ``session_path`` (``fit``: its identified
    offsets); ``report``: the page already written (the demo's); ``rehearsal_writeback``:
    the offsets can be written to the simulator still running (the wizard's)."""
    from ogacq.record.document import build_record  # not at start-up
    from ogacq.record.identity import session_record_id

    session = load_session(session_path)
    try:
        record: Mapping[str, Any] = build_record(session)
    except Exception as exc:  # the campaign is complete and safe whatever fails here
        log.warning("the record of %s could not be built (%s: %s); `ogacq report` says "
                    "more", session.path, type(exc).__name__, exc)
        record = {"id": session_record_id(session)}
    verdict = fit_verdict(fit)
    steps = next_steps(session, verdict, fit.identifiability.identifiable,
                       simulated=simulated, report=report,
                       rehearsal_writeback=rehearsal_writeback,
                       outliers=described_outliers(fit))
    return CampaignEnd(session.path, record, verdict, steps, report, _carried(session))


def _carried(session: LoadedSession) -> str | None:
    """The validation judged with the effects its calibration's diagnosis found, in
    words: the joint offsets left and the verdict (None when none is carried)."""
    from ogacq.campaign.carried import carried_fit

    carried = carried_fit(session)
    if carried is None:
        return None
    offsets = ", ".join(f"{a} {carried.fit.value(f'joint_offset.{a}'):+.4f}" for a in AXES)
    return (f"{carried.describe()}: joint offsets left {offsets} mm, "
            f"{one_line(fit_verdict(carried.fit))}")


def next_steps(session: LoadedSession, verdict: Verdict, identifiable: bool, *,
               simulated: bool, report: Path | None = None,
               rehearsal_writeback: bool = False, outliers: Sequence[str] = (),
               reported: bool = False) -> tuple[NextStep, ...]:
    """What to do now, most useful first. ``outliers``: readings far from their
    agreeing repeats, which no write-back should follow unseen; ``reported``: the
    record was just issued (``ogacq report``): no step to issue or open it."""
    path = session.path
    from ogacq.campaign.carried import validation_of

    calibrated = validation_of(session)
    if calibrated is not None:
        return (NextStep(f"ogacq report {calibrated} --after {path}",
                         f"the record of {calibrated.name}: as found, and as left by this "
                         "validation"),)
    steps = [] if reported else [
        NextStep(f"open {report}", "the calibration record") if report is not None
        else NextStep(f"ogacq report {path}", "the calibration record")]
    if verdict.state == "inconsistent":
        steps.insert(0, NextStep(f"ogacq diagnose {path}", "what the joint offsets leave "
                                 "out: look before writing anything"))
        return tuple(steps)
    if outliers:
        steps.insert(0, NextStep(f"ogacq diagnose {path}", f"{len(outliers)} reading"
                                 f"{'s lie' if len(outliers) > 1 else ' lies'} far from "
                                 "its repeats, which agree (a misread, a knocked gauge: "
                                 f"{outliers[0]}): check the setup before writing anything"))
        return tuple(steps)
    if not (verdict.consistent and identifiable):
        return tuple(steps)
    campaign = session.header.campaign_file
    if simulated and not rehearsal_writeback:
        steps.append(NextStep("", "a rehearsal: the simulated controller stopped with the "
                                  "command; on the machine, `ogacq offsets write SESSION` "
                                  "then a validation run"))
        return tuple(steps)
    steps.insert(0, NextStep(f"ogacq offsets write {path}", "write the offsets to the "
                             "controller (shown and confirmed first)"))
    if campaign and (rehearsal_writeback or not simulated):  # `ogacq sim`'s still serves
        steps.insert(1, NextStep(f"ogacq run {campaign}", "then a validation run, recorded "
                                 f"as {next_session_name(Path(campaign), path)}"))
    return tuple(steps)


def next_session_name(campaign_file: Path, session: Path) -> str:
    """The session a new run of ``campaign_file`` would record into."""
    from ogacq.campaign.campaign_file import read_campaign
    from ogacq.errors import OgacqError

    try:
        return next_session(read_campaign(campaign_file).session).path.name
    except OgacqError:
        return "the next session of the campaign"
