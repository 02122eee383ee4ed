"""The report's parts on a session made in process from the exact model (seeded noise,
display rounding): the figures carry the session's numbers, the diagnosis JSON of
INTERCHANGE.md is rendered faithfully, and text from the session is escaped."""

from __future__ import annotations

import io
import json
import pickle
import re
from pathlib import Path

import numpy as np
import pytest
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.text import Text

from ogacq.cli.report_cmd import report_diagnosis
from ogacq.diagnose.diagnosis import diagnose
from ogacq.errors import InputError
from ogacq.io.tables import write_readings
from ogacq.model.parameters import vector
from ogacq.record.document import build_record
from ogacq.report import build_report, collect, parse_diagnosis
from ogacq.report.diagnosis_view import DiagnosisFormatError
from ogacq.report.figures import (
    DPI,
    deviations_figure,
    maps_figure,
    parameters_figure,
    png_bytes,
    residuals_figure,
)
from ogacq.report.formatting import measure
from ogacq.report.page import render_page
from ogacq.session.convert import import_readings, session_observations
from ogacq.session.store import load_session
from ogacq.sim.readings import simulated_readings
from ogacq.sim.truth import LeadScrewError, SimTruth
from ogacq.writeback.audit import AuditLog
from tests.diagnose.campaigns import MACHINE, OFFSETS, RICH, layout, simulate
from tests.record.pages import gum, two_significant

# INTERCHANGE.md's diagnosis, with an alternative and a rest nothing explains
DIAGNOSIS = {
    "noise_mm": 0.002,
    "base": {"chi2_dof": 36.6, "rms_mm": 0.0039, "consistent": False},
    "final": {"chi2_dof": 1.9, "rms_mm": 0.0021, "consistent": False},
    "located": [{"leg": "x", "gauge_axis": "y", "share": 0.41},
                {"leg": "y", "gauge_axis": "x", "share": 0.30}],
    "effects": [{"effect": "squareness", "where": "xy", "value": 0.5, "std": 0.01,
                 "unit": "mrad", "alternatives": [{"effect": "axis_offset", "where": "xy"}]},
                {"effect": "unexplained", "where": "z_y", "value": None, "std": None,
                 "unit": "-", "alternatives": []}],
    "parameters": {"joint_offset": {"x": 2.01, "y": 1.98, "z": -2.0}},
}


@pytest.fixture(scope="module")
def session_path(tmp_path_factory) -> Path:
    """Readings of the papers' protocol on a machine whose xy pair is 1 mrad out of square."""
    folder = tmp_path_factory.mktemp("parts")
    obs = simulate({"squareness.xy": 1.0}, seed=11)
    write_readings(folder / "readings.csv", obs.layout, obs.values)
    return import_readings(folder / "readings.csv", MACHINE, folder / "session.jsonl")


def _texts(fig) -> str:
    return " | ".join(t.get_text() for t in fig.findobj(Text))


def test_the_figures_carry_the_numbers_of_the_session(session_path):
    data = collect(load_session(session_path))
    deviations = _texts(deviations_figure(data.deviations))
    for row in data.deviations:
        assert f"{row.before_mm:+.3f}" in deviations, row.name
        assert f"({row.name})" in deviations
    assert "deviation before (mm)" in deviations and "deviation after (µm)" in deviations

    fit = data.fit
    residuals = _texts(residuals_figure(data.residuals, fit.noise_mm, fit.residual_rms_mm))
    assert f"rms {fit.residual_rms_mm * 1e3:.2f} µm" in residuals
    assert f"σ = {fit.noise_mm * 1e3:.2f} µm" in residuals
    assert "residual (µm)" in residuals and "reading number" in residuals

    # each offset with the expanded uncertainty of the record, as every headline says it
    results = build_record(load_session(session_path))["results"]["joint_offset"]
    expanded = {f"joint_offset.{a}": r["U_mm"] for a, r in results.items()}
    parameters = _texts(parameters_figure(fit, expanded=expanded))
    for p in fit.parameters:
        value, U = gum(p.value, expanded[p.name])
        assert f"{value} ± {U} mm (k = 2)" in parameters
        assert f"{two_significant(expanded[p.name] * 1e3)} µm" in parameters
    assert "whiskers: expanded uncertainty U (k = 2)" in parameters
    assert "std" not in parameters
    # without a U (not evaluated), the whiskers are 2 std and say so
    fallback = _texts(parameters_figure(fit))
    assert "(2 std, U not evaluated)" in fallback and "or 2 std" in fallback


def test_a_figure_is_placed_as_matplotlib_places_it_and_drawn_once(session_path, monkeypatch):
    data = collect(load_session(session_path))
    fig = deviations_figure(data.deviations)  # placed by its layout engine: long labels
    placed = pickle.loads(pickle.dumps(fig))
    FigureCanvasAgg(placed)
    saved = io.BytesIO()
    placed.savefig(saved, format="png", dpi=DPI)  # matplotlib's own: a pass to place, one to draw
    draws = []
    draw = Figure.draw
    monkeypatch.setattr(Figure, "draw", lambda f, renderer: draws.append(f) or draw(f, renderer))
    assert png_bytes(fig) == saved.getvalue()
    assert len(draws) == 1


def test_a_diagnosis_is_shown_as_the_json_says(session_path):
    data = collect(load_session(session_path), diagnosis=parse_diagnosis(DIAGNOSIS))
    report = build_report(data, build_record(load_session(session_path)))
    text = re.sub(r"\s+", " ", re.sub(r"<[^>]+>", " ", report.html))
    assert "partly explained by squareness.xy; the rest sits at z_y" in text
    assert "joint offsets only 3.90 µm 36.60" in text and "2.10 µm 1.90" in text
    assert "y_x x y 41%" in text
    assert f"squareness.xy {measure(0.5, 0.01, 'mrad')}" in text
    assert "explained equally well by axis_offset.xy: not separable with this campaign" in text
    assert "what would separate them" in text
    assert "unexplained misfit at z_y" in text
    assert "+2.01000" in text  # the final model's offsets beside the offsets-only ones
    # the figure of residuals before and after the effect, refitted from the readings
    assert [f.name for f in report.figures][-1] == "diagnosis.png"
    before, after = data.diagnosis_steps
    assert after.label == "+ squareness.xy"
    assert after.rms_mm < 0.6 * before.rms_mm
    assert after.rms_mm < 1.5 * MACHINE.gauge_repeatability_mm


def test_text_from_the_session_is_escaped(session_path, tmp_path):
    lines = session_path.read_text().splitlines(keepends=True)
    header = json.loads(lines[0])
    header.pop("crc")  # edited by hand: no longer the checksummed original
    header["station"] = {"controller": {"profile": "<img src=x onerror=alert(1)>"}}
    header["machine_file"] = "shop & <floor>.toml"
    path = tmp_path / "odd.jsonl"
    path.write_text(json.dumps(header) + "\n" + "".join(lines[1:]))
    edited = load_session(path, accept_edited=True)  # edited by hand: accepted as it stands
    html = render_page(collect(edited), (), build_record(edited))
    assert "<img src=x" not in html
    assert "&lt;img src=x onerror=alert(1)&gt;" in html
    assert "shop &amp; &lt;floor&gt;.toml" in html


def test_a_header_plan_of_another_shape_names_the_session_and_the_key(session_path, tmp_path):
    """The page states the header's plan through its declaration: a plan whose legs are
    not a list is said with the file and the key (it printed the string's letters)."""
    lines = session_path.read_text().splitlines(keepends=True)
    header = json.loads(lines[0])
    header.pop("crc")
    header["plan"] = {"legs": "xyz", "postures": ["zero", "max"], "cycles": 3}
    path = tmp_path / "odd-plan.jsonl"
    path.write_text(json.dumps(header) + "\n" + "".join(lines[1:]))
    with pytest.raises(InputError, match=re.escape(f"{path}: the header's plan.legs must be "
                                                   "a list, got text ('xyz')")):
        collect(load_session(path, accept_edited=True))


@pytest.mark.parametrize(("change", "message"), [
    (lambda d: d.pop("base"), "no 'base'"),
    (lambda d: d["final"].update(consistent="yes"), "final.consistent"),
    (lambda d: d["effects"][0].update(value="big"), "effects[0].value"),
    (lambda d: d.update(noise_mm=None), "diagnosis.noise_mm"),
    # a profile's value that is not a number: named (float() raised a bare ValueError)
    (lambda d: d.update(profiles=[{"leg": "x", "q_mm": ["one"], "gauges": {}}]),
     "diagnosis.profiles[0].q_mm[0] must be a number"),
    (lambda d: d.update(chi2={"final": {"statistic": 1.0}}), "diagnosis.chi2.final.p is missing"),
])
def test_a_malformed_diagnosis_names_the_key(change, message):
    data = json.loads(json.dumps(DIAGNOSIS))
    change(data)
    with pytest.raises(DiagnosisFormatError, match=re.escape(message)):
        parse_diagnosis(data)


def test_values_are_shown_with_the_decimals_their_std_allows():
    assert measure(0.035860, 0.000569, "mm") == "+0.03586 ± 0.00057 mm"
    assert measure(0.5128, 0.0108, "mrad") == "+0.513 ± 0.011 mrad"
    # the std to two significant digits above 100 too (it was "+21643 ± 2394 ppm")
    assert measure(21643.4, 2394.2, "ppm") == "+21600 ± 2400 ppm"
    assert measure(0.03586, 0.00996, "mm") == "+0.036 ± 0.010 mm"
    assert measure(1.2, np.inf, "mm") == "not determined"


def test_a_write_back_recorded_in_the_session_is_shown(session_path, tmp_path):
    path = tmp_path / "written.jsonl"
    path.write_text(session_path.read_text())
    old = {"x": 0.0, "y": 0.0, "z": 0.0}
    new = {"x": 2.00123, "y": 1.99871, "z": -2.00042}
    with AuditLog(load_session(path)) as log:
        log.record("intent", operation="write-1a2b3c4d", action="write", profile="cia402",
                   old_mm=old, new_mm=new)
        log.record("done", operation="write-1a2b3c4d", action="write", old_mm=old,
                   new_mm=new, nvm_saved=True)
    text = re.sub(r"\s+", " ", re.sub(r"<[^>]+>", " ", render_page(
        collect(load_session(path)), (), build_record(load_session(path)))))
    assert "write done" in text and "controller cia402, saved to non-volatile memory" in text
    assert "x 0 +2.00123" in text and "z 0 -2.00042" in text  # as record.json holds them


def test_what_the_record_holds_the_page_takes_from_the_record(session_path):
    """One path: the campaign's status, the verdict and the write-backs on the page are
    the record's (given a record that says otherwise than the session, the page says
    what the record says), while the analysis (deviations, residuals) is the session's."""
    session = load_session(session_path)
    record = build_record(session)
    assert record["campaign"]["status"] == "complete" and not record["writeback"]
    record["campaign"] |= {"status": "stopped", "reason": "stop pressed", "readings": 40,
                           "planned": 72}
    record["verdict"] |= {"state": "inconsistent", "text": "chi2 said so"}
    record["writeback"] = [{"action": "restore", "status": "failed", "when": "at noon",
                            "old_mm": {"x": 0.1}, "new_mm": {"x": 0.0}, "details": "no reply"}]
    text = re.sub(r"\s+", " ", re.sub(r"<[^>]+>", " ", render_page(collect(session), (), record)))
    assert "campaign stopped" in text and "40 readings of 72 planned" in text
    assert "This campaign stopped before its end (stop pressed): 40 readings of 72" in text
    assert "chi2 said so: the model leaves something out" in text
    assert "Written to controller restore failed at noon, see Adjustment" in text
    assert "Deviations per leg and posture" in text and "residual rms" in text


def test_the_maps_calibrate_wrote_are_on_the_page(session_path):
    """``ogacq calibrate``'s ``compensation`` (docs/calibration-record.md 5) is an
    adjustment: the page states it beside the offsets' (ISO/IEC 17025:2017 7.8.4.1 d);
    the record held it in record.json only, the page said nothing of the maps written."""
    session = load_session(session_path)
    figures = {"A_mm": 0.0710642, "B_mm": 0.0, "R_mm": 0.0070619, "E_mm": 0.0654133,
               "M_mm": 0.0654133}
    compensation = {
        "procedure": "C-20261128-fafde9", "outcome": "improved", "reason": "better than before",
        "writes": {"offsets": "write-81bd009e", "maps": "maps-write-db716973"},
        "restores": {}, "maps": {"x": {"source": "encoder scale +408 ± 35 ppm (k = 2)",
                                       "checksum": "2138706"}},
        "compensated": ["encoder_scale.x"], "uncompensated": ["squareness.xy"],
        "iso230_2": {"before": {"x": figures},
                     "after": {"x": figures | {"A_mm": 0.0164401, "E_mm": 0.0066396}}},
        "tables": [{"format": "linuxcnc", "files": ["tables/linuxcnc/x.comp"], "problem": None},
                   {"format": "fanuc", "files": [], "problem": "too many points"},
                   {"format": "siemens", "files": ["tables/siemens/AX_EEC.INI"],
                    "problem": "siemens: axis y: predicted no better than none"}]}
    record = build_record(session, compensation=compensation)
    text = re.sub(r"\s+", " ", re.sub(r"<[^>]+>", " ", render_page(collect(session), (), record)))
    assert "Error maps (ogacq calibrate C-20261128-fafde9)" in text
    assert "calibrate improved better than before" in text
    assert "offsets write-81bd009e, maps maps-write-db716973" in text
    assert "Corrected by the maps: encoder_scale.x; left uncompensated" in text
    assert "squareness.xy" in text
    assert "x encoder scale +408 ± 35 ppm (k = 2) 2138706" in text
    assert "x before 71.06 0.00 7.06 65.41 65.41" in text  # µm, as the tables' comments
    assert "x after (the validation campaign) 16.44 0.00 7.06 6.64 65.41" in text
    assert "linuxcnc: tables/linuxcnc/x.comp" in text
    assert "fanuc: not written: too many points" in text
    # an axis left out of a format that wrote the others: both said
    assert ("siemens: tables/siemens/AX_EEC.INI; not written: siemens: axis y: predicted no "
            "better than none") in text
    # a record without it (ogacq report of a campaign) has no such section
    assert "Error maps (ogacq calibrate" not in render_page(collect(session), (),
                                                            build_record(session))


def test_a_scans_error_maps_are_drawn_and_stated(tmp_path):
    """A scan of a machine with a cyclic error on its x screw, diagnosed here: the
    report states the map's place and shape, the chi-square before and after, and
    draws the residuals along each leg and the map with its band."""
    truth = SimTruth(vector(OFFSETS), lead_screw={0: LeadScrewError(0.008, 20.0, 0.0)})
    obs = simulated_readings(MACHINE, layout(scan_step_mm=5.0, cycles=2), truth,
                             scatter_mm=0.002, step_mm=0.001, seed=4)
    write_readings(tmp_path / "scan.csv", obs.layout, obs.values)
    session = load_session(import_readings(tmp_path / "scan.csv", MACHINE,
                                           tmp_path / "scan.jsonl"))
    result = diagnose(session_observations(session))
    assert [e.name for e in result.effects] == ["lead_screw_cyclic.x"]
    view = parse_diagnosis(report_diagnosis(result, session))
    assert len(view.maps) == 1 and view.profiles and view.chi2["final"].consistent
    report = build_report(collect(session, diagnosis=view), build_record(session))
    assert {"profiles.png", "maps.png"} <= {f.name for f in report.figures}
    text = re.sub(r"\s+", " ", re.sub(r"<[^>]+>", " ", report.html))
    assert "x axis, q from -100 to +60 mm, cyclic lead-screw error of pitch" in text
    assert "Along each axis" in text and "with the maps too (final)" in text
    maps = _texts(maps_figure(view.maps))
    assert "x axis: cyclic lead-screw error" in maps and "forward ±2u" in maps


def test_a_diagnosis_left_unexplained_is_reported(tmp_path):
    """A lead-screw error read at five positions per leg: nothing of the library or the
    maps explains it; the report's diagnosis keeps the "unexplained" entry (it once
    stopped the report: the entry has no effect of its own to pair with)."""
    obs = simulate({}, 1, lay=layout(RICH), lead_screw=(0.02, 16.0))
    write_readings(tmp_path / "r.csv", obs.layout, obs.values)
    session = load_session(import_readings(tmp_path / "r.csv", MACHINE, tmp_path / "s.jsonl"))
    result = diagnose(session_observations(session))
    assert result.outcome == "unexplained"
    view = parse_diagnosis(report_diagnosis(result, session))
    assert view.unexplained_where == result.unexplained
    assert view.proposals  # a scan would show what three positions per leg cannot
