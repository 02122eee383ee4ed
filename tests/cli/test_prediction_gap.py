"""The gap between the figures `ogacq calibrate` predicts after its correction and those
its validation measures, explained (issue 38.8): an encoder-scale calibration predicted
A 6.90 µm after and its validation measured 13.08 µm, with no comment.

Both are ISO 230-2 figures of a map with its u as the s: A is the error left (E)
widened by two u either side. The prediction is the written map with its error taken
away (four u of a map the scan measured densely); the validation identifies what is
left afresh from its own, fewer readings: its u makes most of its A."""

from __future__ import annotations

import io
import re
from types import SimpleNamespace

import numpy as np
from rich.console import Console

from ogacq.calibration.validate import Judgement
from ogacq.cli import render_calibrate
from ogacq.compensation.iso230 import map_figures
from ogacq.model.axis_map import AxisMap
from tests.compensation.maps import screw_map

Q = tuple(np.arange(-100.0, 60.0 + 1e-9, 10.0))


def _left(scale_ppm: float, u_mm: float) -> dict:
    """The figures of what a validation finds left on x: a scale error, known to u."""
    error = tuple(scale_ppm * 1e-6 * q for q in Q)
    found = AxisMap("x", Q, error, error, tuple(u_mm for _ in Q), tuple(u_mm for _ in Q))
    return {**map_figures(found).to_json(), "u_max_mm": u_mm}


def _shown(monkeypatch, after: dict) -> str:
    out = io.StringIO()
    monkeypatch.setattr(render_calibrate, "console", Console(file=out, width=400))
    monkeypatch.setattr(render_calibrate.render_offsets, "print_plan", lambda *a, **k: None)
    ui = render_calibrate.TerminalUI(yes=True, on_recorded=None)
    written = screw_map(u_mm=0.0004)  # known to 0.4 µm (forward), 0.6 µm (reverse)
    ui.compensation(SimpleNamespace(uncompensated=(), not_applied=(), maps={"x": written},
                                    tables=()),
                    SimpleNamespace(refusals=[]), None)  # type: ignore[arg-type]
    before = {"x": map_figures(written).to_json()}
    verdict = {"state": "consistent", "p_value": 0.5, "text": "within the gauge noise (...)"}
    ui.validation(Judgement("validated", (), verdict, 1.0, 1.0, {}, {}, {}, before,
                            {"x": after}))
    return out.getvalue()


def test_a_validation_whose_own_uncertainty_widens_a_says_so(monkeypatch):
    after = _left(6.0, 0.0034)  # E 0.96 µm left, measured to 3.4 µm
    text = _shown(monkeypatch, after)
    assert ("A 14.56 µm against 2.40 µm predicted (no error left, two u either side: the "
            "written map's u 0.60 µm): this validation finds E 0.96 µm left, within that "
            "band, with two u of its own measure either side (u up to 3.40 µm): how well "
            "it checks the axis, not an error of the machine") in text, text
    assert re.search(r"axis x: A \d+\.\d\d -> 14\.56 µm, B \d+\.\d\d -> \d+\.\d\d µm, "
                     r"E \d+\.\d\d -> 0\.96 µm \(ISO 230-2, from the maps\)", text), text


def test_an_error_left_beyond_the_predicted_band_is_said_to_be_one(monkeypatch):
    text = _shown(monkeypatch, _left(60.0, 0.0002))  # E 9.6 µm, well measured
    assert "the written map's u 0.60 µm): E 9.60 µm is left, beyond that band: the " \
           "correction left part of the error" in text, text


def test_a_validation_within_the_prediction_needs_no_words(monkeypatch):
    text = _shown(monkeypatch, _left(1.0, 0.0003))
    assert "µm predicted" not in text and "axis x: A" in text
