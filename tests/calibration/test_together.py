"""Two sessions of one simulated machine, the second after an offsets write (the
calibration's own validation), fitted together: the joint offsets come out in the
first session's frame, as each alone gives them, with a smaller std. Fitted together
at their nominal coordinates (the offsets' change left out), they do not."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest

from ogacq.calibration.together import frame_shift_mm, observations_together, sent_targets
from ogacq.errors import InputError
from ogacq.identify.fit import FitResult, fit
from ogacq.identify.noise import noise_for
from ogacq.identify.observations import Observations, readings_together
from ogacq.model.parameters import AXES, PARAM_SETS
from ogacq.session.convert import session_observations
from ogacq.session.store import LoadedSession, load_session
from tests.calibration.test_calibrate_e2e import calibrated, effects_file

OFFSETS = tuple(f"joint_offset.{a}" for a in AXES)


@pytest.fixture(scope="module")
def written(tmp_path_factory) -> tuple[LoadedSession, LoadedSession]:
    """The calibration campaign and the validation run after its offsets were written."""
    root = tmp_path_factory.mktemp("together")
    folder = calibrated(root, ["--simulator", "--effects",
                               str(effects_file(root, "[gauges]\nnoise_mm = 0.0005\n")),
                               "--seed", "3", "--speed", "100", "--no-separate", "--yes",
                               "--history", "none"])
    return (load_session(folder / "calibration.jsonl"),
            load_session(folder / "validation.jsonl"))


def offsets_fit(obs: Observations) -> FitResult:
    return fit(obs, PARAM_SETS["offsets"], method="exact", weighting="gls",
               noise=noise_for(obs))


def values(result: FitResult) -> tuple[np.ndarray, np.ndarray]:
    at = [result.names.index(n) for n in OFFSETS]
    return result.theta[at], result.std[at]


def test_the_offsets_of_two_sessions_fitted_together_in_the_first_frame(written):
    first, second = written
    shift = frame_shift_mm(second, first)
    assert np.abs(shift).max() > 0.1  # the write moved the offsets
    rho1, std1 = values(offsets_fit(session_observations(first)))
    rho2, std2 = values(offsets_fit(session_observations(second)))
    both, std = values(offsets_fit(observations_together([first, second])))
    # the second alone, in the first's frame: q1 = q2 + (o2 - o1)
    for k in range(3):
        assert abs(both[k] - rho1[k]) < 4 * math.hypot(std[k], std1[k]), (k, both, rho1)
        assert abs(both[k] - (rho2[k] - shift[k])) < 4 * math.hypot(std[k], std2[k])
    assert np.all(std < std1) and np.all(std < std2), (std, std1, std2)
    # at the nominal coordinates, the two frames mixed: far from either
    mixed, _ = values(offsets_fit(readings_together([session_observations(first),
                                                     session_observations(second)])))
    assert np.abs(mixed - rho1).max() > 20 * std.max(), (mixed, rho1)


def test_without_maps_a_reading_s_target_sent_is_its_own(written):
    first, _ = written
    # without maps the runner recorded no commanded_mm: the target sent is the reading's q
    assert np.array_equal(sent_targets(first), [r.q_mm for r in first.readings])


def test_sessions_whose_offsets_were_not_recorded_are_not_combined(written, tmp_path):
    first, second = written
    blind = LoadedSession(Path(tmp_path / "blind.jsonl"),
                          dataclasses.replace(first.header, station={}), first.records)
    with pytest.raises(InputError, match="offsets the controller held are not recorded"):
        frame_shift_mm(blind, second)
