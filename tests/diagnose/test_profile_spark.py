"""A leg's misfit line on a designed scan's sparse targets: a cell with no bin read is
blank, and nothing is warned (found: ``ogacq diagnose separating.jsonl`` of a 411-step
designed scan printed numpy's "RuntimeWarning: Mean of empty slice" into the
diagnosis, from ogacq/diagnose/profile.py)."""

from __future__ import annotations

import warnings

import numpy as np

from ogacq.diagnose.profile import LegProfile


def test_cells_of_unread_bins_are_blank_without_a_warning():
    rms = np.array([0.001, np.nan, np.nan, 0.002])
    profile = LegProfile(0, np.arange(4.0), ("y_x",), rms[None], rms[None], rms, rms,
                         np.array([3, 0, 0, 3]))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        line = profile.spark(width=4)
    assert line[1:3] == "  " and line[0] != " " and line[3] == "█"
