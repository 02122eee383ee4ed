"""``ogacq diagnose``: is the identified model within the gauge noise, and if not,
what physics was left out (INTERCHANGE.md)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from ogacq.cli.options import (
    AcceptEditedOption,
    HistoryOption,
    JsonOption,
    OtherGeometryOption,
    PartialOption,
    RecordedMachineOption,
)
from ogacq.diagnose.diagnosis import DiagnosisError, diagnose
from ogacq.errors import InputError
from ogacq.identify.plausibility import check_result
from ogacq.io.loading import load_input
from ogacq.io.machine_file import read_machine
from ogacq.model.parameters import PARAM_SETS


def diagnose_command(
    file: Annotated[Path, typer.Argument(help="Readings CSV, deviations CSV or session.")],
    machine: RecordedMachineOption = None,
    other_geometry: OtherGeometryOption = False,
    partial: PartialOption = False,
    accept_edited: AcceptEditedOption = False,
    as_json: JsonOption = False,
    history: HistoryOption = None,
) -> None:
    """Compare the recordings with the identified model; locate and explain a mismatch.

    The diagnosis of a session is recorded in the machine's history with the
    session's calibration (not with --other-geometry: another machine's; nor of a
    campaign not finished: its complete result is recorded when it completes).
    """
    spec = read_machine(machine) if machine is not None else None
    loaded = load_input(file, spec, PARAM_SETS["offsets"], machine_path=machine,
                        other_geometry=other_geometry, partial=partial,
                        accept_edited=accept_edited)
    try:
        result = diagnose(loaded.observations)
    except DiagnosisError as exc:
        raise InputError(file, str(exc)) from None
    check_result(result.final_fit)
    # The JSON or text rendering and the history (sessions) are imported only when
    # used: start-up is most of a short campaign's diagnosis.
    if as_json:
        import json

        print(json.dumps({**result.to_json(), **loaded.state_json()}))
    else:
        from ogacq.cli.render_diagnosis import print_diagnosis, print_next
        from ogacq.cli.render_fit import print_notes

        print_notes(loaded.notes())
        print_diagnosis(result, machine_file=str(machine or file))
        if loaded.session is not None:
            print_next(result, str(file),
                       controller_gone=loaded.session.header.simulator is not None)
    from ogacq.history.location import recording_off

    if loaded.session is not None and not other_geometry and not recording_off(history):
        # the recording (its write-back readers, their profiles) imported only to record
        from ogacq.history.recording import record_diagnosis

        record_diagnosis(file, result.to_json(), history, accept_edited=accept_edited)
