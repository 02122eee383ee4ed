"""What a technician does after reading the record ``ogacq report`` issued (issue
38.5): every command ends with the next one, naming the file, or says why there is
nothing more."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

from ogacq.cli.campaign_end import NextStep, next_session_name, next_steps
from ogacq.session.records import OffsetsRecord
from ogacq.session.series import earlier_in_series, numbered

if TYPE_CHECKING:
    from ogacq.identify.fit import FitResult
    from ogacq.record.calibration_record import CalibrationRecord
    from ogacq.session.store import LoadedSession


def after_report(calibration: LoadedSession, validation: LoadedSession | None,
                 record: CalibrationRecord, fit: FitResult | None,
                 validation_fit: FitResult | None) -> tuple[NextStep, ...]:
    """The next steps after the record of ``calibration`` (``--after``: ``validation``)
    was issued; ``fit``, ``validation_fit``: their identifications (None: none)."""
    from ogacq.identify.consistency import fit_verdict

    path = calibration.path
    compensation = record.compensation_section
    if compensation is not None:
        return (NextStep("", f"nothing more: the record of `ogacq calibrate`'s procedure, "
                             f"which wrote the corrections and judged them itself "
                             f"({compensation.outcome})"),)
    if validation is not None:
        if validation_fit is not None and not _validated(validation, validation_fit):
            return (NextStep(f"ogacq diagnose {validation.path}", "the validation is not "
                             "within the gauge noise: what the write-back left"),)
        return (NextStep("", "nothing more: the record states the machine as found and as "
                             "left by the validation"),)
    procedure = _procedure_page(calibration)
    if procedure is not None:
        return procedure
    if fit is None:
        return (NextStep("", "nothing to write from this campaign: its joint offsets "
                             "could not be identified (the record says why)"),)
    # the built-in simulator stops with the command that started it: nothing is left
    # to write to or to validate against (`ogacq sim`'s drives are there still)
    gone = calibration.header.simulator is not None
    if any(r.stage == "done" for r in calibration.of_type(OffsetsRecord)):
        return (NextStep("", "nothing more: a rehearsal on the built-in simulator, which "
                             "stopped with the command that wrote its offsets; on the "
                             "machine a validation run follows the write-back"),) if gone \
            else _validation_of_written(calibration)
    verdict = fit_verdict(fit)
    from ogacq.diagnose.outliers import described_outliers

    steps = next_steps(calibration, verdict, fit.identifiability.identifiable,
                       simulated=gone, reported=True, outliers=described_outliers(fit))
    if steps:
        return steps
    why = (verdict.summary() if not verdict.consistent else
           "; ".join(fit.identifiability.reasons) or "not every offset is determined")
    return (NextStep("", f"nothing to write from {path.name}: {why}"),)


def _procedure_page(session: LoadedSession) -> tuple[NextStep, ...] | None:
    """A campaign of an ``ogacq calibrate`` procedure, reported alone: the procedure's
    record is the one to read (its log beside the session names it); None for any
    other campaign."""
    from ogacq.calibration.log import LOG_NAME
    from ogacq.session.records import CalibrateRecord
    from ogacq.session.store import load_session

    log = Path(session.path).parent / LOG_NAME
    try:
        steps = load_session(log).of_type(CalibrateRecord) if log.is_file() else []
    except Exception:  # an unreadable log names no campaign
        return None
    if not any(Path(str(r.details.get("session", ""))).name == Path(session.path).name
               for r in steps):
        return None
    page = log.parent / "report" / "report.html"
    why = (f"{Path(session.path).name} is a campaign of the `ogacq calibrate` procedure "
           f"logged in {log}, which wrote the corrections and judged them itself")
    return (NextStep(f"open {page}", f"its record, as found and as left: {why}"),) \
        if page.is_file() else (NextStep("", f"nothing more here: {why}"),)


def _validated(validation: LoadedSession, fit: FitResult) -> bool:
    """Whether the validation is within the noise, judged as its own end judges it:
    after a write-back from a diagnosis, with that diagnosis's effects carried over (its
    joint offsets alone are biased by them, issue 38.4)."""
    from ogacq.campaign.carried import carried_fit
    from ogacq.identify.consistency import fit_verdict

    if fit_verdict(fit).consistent:
        return True
    carried = carried_fit(validation)  # a diagnosis of the calibration: only when needed
    return carried is not None and fit_verdict(carried.fit).consistent


def _validation_of_written(calibration: LoadedSession) -> tuple[NextStep, ...]:
    """The offsets identified here were written: their validation, or its record when
    the validation has run (the session after this one in its series)."""
    path = calibration.path
    earlier = earlier_in_series(path)  # session-2.jsonl: [session.jsonl]
    later = numbered(earlier[-1] if earlier else path, len(earlier) + 2)
    if later.exists():
        return (NextStep(f"ogacq report {path} --after {later}", "the record as found and "
                         f"as left, with the validation {later.name}"),)
    campaign = calibration.header.campaign_file
    if not campaign:
        return (NextStep("", f"the offsets were written: a validation campaign, then "
                             f"`ogacq report {path} --after VALIDATION_SESSION`"),)
    return (NextStep(f"ogacq run {campaign}", "the offsets were written: the validation, "
                     f"recorded as {next_session_name(Path(campaign), path)}; then "
                     f"`ogacq report {path} --after` it"),)
