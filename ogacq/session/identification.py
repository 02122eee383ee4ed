"""The joint offsets of a session: those its campaign recorded when it finished,
with their statistics on its readings, or identified afresh. Apart from the
campaign's run so that what reads a finished session (the record, the report, the
history) does not load the station and its drivers."""

from __future__ import annotations

from ogacq.identify.fit import FitResult, evaluate, fit
from ogacq.identify.plausibility import check_observations, check_result
from ogacq.model.parameters import PARAM_SETS
from ogacq.session.convert import session_observations
from ogacq.session.store import LoadedSession


def identify_session(session: LoadedSession) -> FitResult:
    """The joint offsets from every raw reading, by the exact nonlinear fit."""
    obs = session_observations(session)
    check_observations(obs, PARAM_SETS["offsets"])
    result = fit(obs, PARAM_SETS["offsets"])
    check_result(result)
    return result


def recorded_identification(session: LoadedSession) -> FitResult:
    """The joint offsets the campaign recorded when it finished, with their residuals
    and statistics on the session's readings; identified afresh when the session
    records none (a campaign stopped before its end, an imported table)."""
    recorded = session.result
    names = PARAM_SETS["offsets"]
    if recorded is None or recorded.params != "offsets":
        return identify_session(session)
    try:
        values = recorded.values(names)
    except (KeyError, TypeError, ValueError):  # a result of another shape: not ours to read
        return identify_session(session)
    return evaluate(session_observations(session), names, values)
