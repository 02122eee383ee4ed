"""Step 4: the result in words a technician can act on, then the write-back."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from ogacq.campaign.run import CampaignOutcome
from ogacq.cli.plain import shown, table_of
from ogacq.cli.verdict_text import one_line
from ogacq.cli.wizard.ui import Screen
from ogacq.identify.consistency import fit_verdict
from ogacq.record.calibration_record import CalibrationRecord
from ogacq.uncertainty.reporting import expanded_mm, result_headline, rounded


def show_result(screen: Screen, outcome: CampaignOutcome, record: Mapping[str, Any],
                title: str = "Joint offsets identified", truth: bool = True) -> bool:
    """Print the identified offsets, each with its expanded uncertainty U from the
    campaign's ``record`` (k = 2, the one headline rule), every number in mm; True
    when they are fit to be written back. ``truth``: a rehearsal's hidden offsets
    beside them (not beside what remains after a write-back)."""
    fit = outcome.fit
    results = CalibrationRecord.from_json(record).results
    truth = truth and outcome.hidden is not None
    screen.say(f"[bold]{title} from {len(fit.observations)} readings (mm)[/]")
    table = table_of("joint", ">offset", ">± U (k = 2)", *([">simulator's truth"] if truth else []))
    incomplete = False
    for name, value, std in zip(fit.names, fit.values, fit.std, strict=True):
        line = result_headline(results, name, float(value), "mm")
        incomplete |= not line.complete
        row = [name.replace("joint_offset.", ""),
               line.value if np.isfinite(std) else "not determined",
               line.U or ("not evaluated" if np.isfinite(std) else "")]
        if truth and outcome.hidden is not None:
            row.append(rounded(outcome.hidden.get(name, 0.0),
                               expanded_mm(results, name), sign=True))
        table.add_row(*row)
    screen.say(table)
    if incomplete:
        screen.say("[yellow]U leaves out what was not recorded (a certificate, a "
                   "temperature): the record lists it.[/]")
    # one unit on this screen: mm, as the offsets
    screen.say(f"Residual rms {fit.residual_rms_mm:.2g} mm; gauge noise "
               f"{fit.noise.describe()}.")
    ident = fit.identifiability
    writable = True
    if ident.identifiable:
        screen.ok(f"identifiable: every offset is determined by these readings "
                  f"(condition number {ident.condition_number:.3g})")
    else:
        writable = False
        screen.problem("not identifiable: do not write these offsets")
        for reason in ident.reasons:
            screen.say(f"     {shown(reason)}")
    verdict = fit_verdict(fit)
    if verdict.consistent:
        screen.ok(f"fit {one_line(verdict)}")
    else:
        writable = False
        screen.problem(f"fit {one_line(verdict)}")
        if verdict.state == "inconsistent":
            screen.say("     something the model leaves out (a loose stand, play, a bent "
                       f"leg). Look before writing: ogacq diagnose "
                       f"{shown(outcome.session_path)}")
    screen.say(f"Session: {shown(outcome.session_path)}")
    return writable


def offer_writeback(screen: Screen, session: Path, writable: bool,
                    campaign: Path | None = None, rehearsal: bool = False,
                    history: str | None = None) -> bool:
    """Offer ``ogacq offsets write`` (run here, with its own confirmation), or say it;
    True when written. ``campaign`` names the controller where the session's cannot
    (a rehearsal's simulator does not outlive the command that starts it)."""
    command = ["offsets", "write", str(session)]
    if campaign is not None:
        command += ["--campaign", str(campaign)]
    if history is not None:
        command += ["--history", history]
    typed = "ogacq " + " ".join(command)
    if not writable:
        screen.say(f"When the cause is fixed and a new campaign is consistent, write the "
                   f"offsets with: {shown(typed)}")
        return False
    # one confirmation: the write-back's own, once it has shown the old and new values
    screen.say("The write-back: the controller's offsets and the new ones, then your "
               "confirmation.")
    from ogacq.cli.app import main
    from ogacq.cli.offsets_cmd import EXIT_DECLINED

    code = main(command)
    later = ("rehearsal: the simulated controller stops with the wizard; on the machine, "
             "[bold]ogacq offsets write SESSION[/]" if rehearsal else
             f"later: [bold]{shown(typed)}[/]")
    if code == EXIT_DECLINED:
        screen.say(f"Not written ({later}).")
        return False
    if code != 0:
        screen.problem(f"the write-back stopped (exit {code}): nothing more is written "
                       f"here ({later})")
        return False
    _say_what_a_power_cycle_does(screen, session, rehearsal)
    return True


def offer_report(screen: Screen, session: Path, folder: Path,
                 validation: Path | None = None, history: str | None = None) -> Path | None:
    """Offer the calibration record (``ogacq report``, with the validation as the as-left
    measurement when there is one) into ``folder``; its page, or None when declined."""
    what = "as found and as left" if validation is not None else "report.html, record.json"
    if not screen.confirm(f"Write the calibration record now ({what}, in "
                          f"{shown(folder)}/)?", default=True):
        later = f"ogacq report {session}" + (f" --after {validation}" if validation else "")
        screen.say(f"Not written. Later: [bold]{shown(later)}[/]")
        return None
    from ogacq.cli.report_cmd import report_of  # matplotlib: only when a record is made
    from ogacq.report.record_view import revision_label

    screen.say("Writing the calibration record …")
    page, record = report_of(session, folder, validation, history)
    screen.ok(f"record {revision_label(CalibrationRecord.from_json(record))}: {page}")
    return page


def _say_what_a_power_cycle_does(screen: Screen, session: Path, rehearsal: bool) -> None:
    """After a write-back: whether the values written outlive a power cycle of the
    drive (the session's record of it says), so the job is not called done unsaid."""
    from ogacq.session.records import OffsetsRecord
    from ogacq.session.store import load_session
    from ogacq.writeback.outcome import Stage

    done = [r for r in load_session(session).of_type(OffsetsRecord) if r.stage == Stage.DONE]
    if not done or done[-1].details.get("survives_power_cycle") is not False:
        return
    where = " (rehearsal: the simulated drive)" if rehearsal else ""
    screen.say(f"[yellow]The offsets written are not in the drive's non-volatile "
               f"memory{where}: switching the drive off and on brings back the ones it "
               f"saved before.[/] Save them with the drive's own panel or software, or "
               f"write them again with --save-nvm where the profile can save.")
