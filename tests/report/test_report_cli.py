"""``ogacq report`` on real simulated campaigns (drivers, gauges on pseudo-terminals,
Modbus controller): the HTML is self-contained, the figures exist, and the page
carries the session's own numbers."""

from __future__ import annotations

import base64
import hashlib
import json
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from ogacq.calibration.log import ProcedureLog
from ogacq.cli.app import main
from ogacq.cli.report_cmd import issue_report
from ogacq.identify.observations import averaged_deviations
from ogacq.record.document import build_record
from ogacq.session.convert import session_observations
from ogacq.session.records import EndRecord, FaultRecord
from ogacq.session.store import SessionWriter, load_session
from tests.campaign.conftest import write_campaign
from tests.cli.helpers import run_ogacq
from tests.record.pages import gum

FIGURES = ("deviations.png", "residuals.png", "parameters.png", "diagnosis.png")
# the offsets a write-back leaves: what a validation campaign should find
VALIDATION_EFFECTS = "[joint_offset]\nx = 0.0012\ny = -0.0008\nz = 0.0005\n"


def _campaign(folder: Path, effects: str) -> Path:
    path = write_campaign(folder, seed=3, line_at_speed=True)
    (folder / "effects.toml").write_text(effects)
    text = path.read_text().replace("[simulator]\n", '[simulator]\neffects = "effects.toml"\n')
    path.write_text(text)
    return path


@pytest.fixture(scope="module")
def sessions(tmp_path_factory) -> tuple[Path, Path]:
    """A calibration campaign on a machine with an out-of-square xy pair, and a
    validation campaign after the write-back, run side by side."""
    root = tmp_path_factory.mktemp("report")
    paths = [_campaign(root / "calibration", "[squareness]\nxy = 0.5\n"),
             _campaign(root / "validation", VALIDATION_EFFECTS)]
    procs = [subprocess.Popen([sys.executable, "-m", "ogacq", "run", str(p), "--json"],
                              stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
             for p in paths]
    for proc in procs:
        _, err = proc.communicate(timeout=120)
        assert proc.returncode == 0, err
    return root / "calibration" / "session.jsonl", root / "validation" / "session.jsonl"


def _text(html: str) -> str:
    """The page as a reader sees it: no tags, no embedded images."""
    html = re.sub(r"data:image/png;base64,[A-Za-z0-9+/=]+", "", html)
    html = re.sub(r"<style>.*?</style>", "", html, flags=re.S)
    return re.sub(r"\s+", " ", re.sub(r"<[^>]+>", " ", html)).replace("&gt;", ">")


def _row_numbers(html: str, label: str) -> list[float]:
    """The numbers of the table row that starts with ``label``."""
    row = re.search(rf"<tr><t[dh][^>]*>{re.escape(label)}</t[dh]>(.*?)</tr>", html)
    assert row, f"no table row {label!r}"
    return [float(x) for x in re.findall(r"[-+]?\d+\.\d+", row.group(1))]


def test_report_of_a_campaign_is_self_contained_and_carries_its_numbers(sessions, tmp_path):
    calibration, validation = sessions
    out = tmp_path / "out"
    proc = run_ogacq("report", calibration, "--after", validation, "--out", out)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.splitlines()[0] == str(out / "report.html")  # then the next step
    html = (out / "report.html").read_text(encoding="utf-8")

    # self-contained: every source is a data: URI, nothing fetched, nothing run
    sources = re.findall(r"""(?:src|href)\s*=\s*["']([^"']*)""", html, flags=re.I)
    assert sources and all(s.startswith("data:image/png;base64,") for s in sources)
    assert not re.search(r"https?://|<script|<link|url\(|@import", html, flags=re.I)

    # the figures: valid PNGs of a legible size, each embedded in the page
    for name in FIGURES:
        data = (out / name).read_bytes()
        assert data.startswith(b"\x89PNG\r\n\x1a\n"), name
        with Image.open(out / name) as image:
            image.verify()
        with Image.open(out / name) as image:
            assert image.width >= 900 and image.height >= 300, (name, image.size)
        assert base64.b64encode(data).decode() in html, name

    # the session's own numbers: the campaign's result record ...
    session = load_session(calibration)
    refit = session.result.refit
    # each offset's headline: U of the record's budget (k = 2) to two significant digits,
    # the value at its decimal place (JCGM 100:2008 7.2.6); the fit std as the detail
    record = json.loads((out / "record.json").read_text())
    parameters = html[html.index('<h2 id="parameters"'):]  # the analysis's table
    for axis in "xyz":
        row = re.search(rf"<tr><td>joint_offset\.{axis}</td>(.*?)</tr>", parameters).group(1)
        entry = record["results"]["joint_offset"][axis]
        assert entry["value_mm"] == pytest.approx(refit["parameters"]["joint_offset"][axis])
        value, U = gum(entry["value_mm"], entry["U_mm"])
        assert f"{value} ± {U} mm (k = 2" in row, row  # "; budget incomplete" may follow
        std = float(re.search(r"(\d\.\d+) mm</td>", row).group(1))
        assert std == pytest.approx(refit["std"]["joint_offset"][axis], rel=0.05)
        assert std < entry["U_mm"] / 2  # the budget holds more than the fit's noise
        # what remains after the write-back, with the U of the validation's own budget
        left = record["validation_results"]["joint_offset"][axis]
        value, U = gum(left["value_mm"], left["U_mm"])
        assert f"{value} ± {U} mm (k = 2" in row.split("</td>")[-2], row
    text = _text(html)
    # the page shows 2 decimals of the full-precision fit, the result record holds 6 of
    # mm: the two may round either side of a hundredth of a um
    for label, value_mm in (("residual rms", refit["residual_rms_mm"]),
                            ("gauge noise σ", session.result.noise_mm)):
        shown = [float(v) for v in re.findall(rf"{label} (\d+\.\d\d) µm", text)]
        assert any(v == pytest.approx(value_mm * 1e3, abs=0.0051) for v in shown), \
            (label, shown, value_mm)
    # ... the deviations measured before, from the raw readings ...
    before = averaged_deviations(session_observations(session), "12")
    for name, value in zip(before.labels, before.values, strict=True):
        assert _row_numbers(html, name)[0] == pytest.approx(value, abs=1e-4)
    # ... the machine, the station and the software that recorded it
    assert "leg length 310.25 mm" in text and "gauge resolution 0.001 mm" in text
    assert f"recorded by {session.header.software}" in text
    assert "mitutoyo-01a" in text and "cia402" in text

    # the validation campaign: measured deviations after write-back, small remaining offsets
    assert "after, measured (µm)" in text and "remaining after write-back" in text
    remaining = _row_numbers(parameters, "joint_offset.x")[-2]
    assert abs(remaining) < 0.005
    # the diagnosis ran here and names the out-of-square pair, with the fit then in noise
    assert "explained by squareness.xy" in text
    assert re.search(r"squareness\.xy \+0\.[45]\d* ± 0\.\d+ mrad", text)


def _copy_records(source: Path, target: Path, keep: int, tail: str = "") -> Path:
    lines = source.read_text().splitlines(keepends=True)
    target.write_text("".join(lines[:keep]) + tail)
    return target


def _report(*args: object) -> int:
    return main(["report", *map(str, args)])


def test_a_stopped_or_torn_campaign_still_renders_with_a_clear_note(sessions, tmp_path,
                                                                     capsys):
    calibration, _ = sessions
    lines = calibration.read_text().splitlines()
    half = next(k for k, line in enumerate(lines) if '"y/c2/' in line)
    reason = "gauge z_y: no reply within 2.0 s"
    stopped = _copy_records(calibration, tmp_path / "stopped.jsonl", half)
    with SessionWriter.append_to(stopped) as writer:  # sealed as a campaign writes them
        writer.write(FaultRecord(during="read", step="y/c2/p1", gauge="z_y", attempt=3,
                                 error="DeviceTimeout", message=reason))
        writer.write(EndRecord(status="stopped", reason=reason))
    torn = _copy_records(calibration, tmp_path / "torn.jsonl", half,
                         lines[half][: len(lines[half]) // 2])

    assert _report(stopped, "--out", tmp_path / "stopped") == 4  # not finished
    assert "partial: " in capsys.readouterr().err
    assert _report(stopped, "--out", tmp_path / "stopped", "--partial") == 0
    assert f"partial: {len(load_session(stopped).readings)} of 72 planned readings" in \
        capsys.readouterr().err
    text = _text((tmp_path / "stopped" / "report.html").read_text(encoding="utf-8"))
    n = len(load_session(stopped).readings)
    assert "campaign stopped" in text
    assert f"This campaign stopped before its end ({reason}): {n} readings of 72 planned" in text
    assert "joint_offset.x" in text  # still identified from what is on file

    consistent = tmp_path / "diagnosis.json"  # a given diagnosis: nothing diagnosed here
    consistent.write_text(json.dumps({"noise_mm": 0.0006, "effects": [],
                                      "base": {"rms_mm": 0.0006, "consistent": True},
                                      "final": {"rms_mm": 0.0006, "consistent": True}}))
    assert _report(torn, "--diagnosis", consistent, "--partial") == 0  # default folder
    assert capsys.readouterr().out.splitlines()[0] == \
        str(tmp_path / "torn-report" / "report.html")
    text = _text((tmp_path / "torn-report" / "report.html").read_text(encoding="utf-8"))
    assert "campaign incomplete" in text and "did not finish (no end record)" in text
    assert "A record cut by a crash was dropped" in text
    assert "consistent: the joint-offset model reproduces the readings" in text
    assert (tmp_path / "torn-report" / "deviations.png").stat().st_size > 1000


@pytest.mark.parametrize("case", ["csv", "no header", "missing", "bad diagnosis",
                                  "procedure log", "positioning test", "itself after"])
def test_bad_input_gives_one_line_and_exit_2(sessions, tmp_path, capsys, case):
    calibration, _ = sessions
    args: list[object]
    if case == "csv":
        path = tmp_path / "readings.csv"
        path.write_text("t_s,cycle,leg,gauge_axis\n0,1,x,y\n")
        args, named = [path], "not an ogacq session"
    elif case == "no header":
        path = tmp_path / "records.jsonl"
        path.write_text('{"type": "reading", "reading_mm": 1.0}\n')
        args, named = [path], "no session header"
    elif case == "missing":
        path = tmp_path / "nowhere.jsonl"
        args, named = [path], "cannot read session"
    elif case == "procedure log":  # ogacq calibrate's: it was refused as partial, exit 4
        ProcedureLog.create(tmp_path, {"mode": "simulator"}).close()
        path = tmp_path / "procedure.jsonl"
        args, named = [path], "is the log of an `ogacq calibrate` procedure"
    elif case == "positioning test":  # ogacq positioning's: reported as nothing identified
        path = tmp_path / "positioning-x.jsonl"
        SessionWriter.create(path, {"kind": "positioning", "positioning": {"axis": "x"}}).close()
        args, named = [path], "is an axis's positioning test by its scale (ogacq positioning)"
    elif case == "itself after":  # the as-found campaign as its own as-left one
        path = tmp_path / "copy.jsonl"
        path.write_bytes(calibration.read_bytes())
        args, named = [calibration, "--after", path], "--after is the calibration campaign"
    else:
        path = tmp_path / "diagnosis.json"
        path.write_text(json.dumps({"noise_mm": 0.001, "final": {"consistent": True}}))
        args, named = [calibration, "--diagnosis", path], "no 'base'"
    assert _report(*args, "--out", tmp_path / "out") == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("ogacq: error: ") and str(path) in err and named in err
    assert len(err.splitlines()) == 1
    assert not (tmp_path / "out" / "report.html").exists()


def test_the_stored_result_and_the_report_agree_on_every_offset(sessions):
    """The report re-identifies with the campaign's own routine: same numbers."""
    from ogacq.report import collect

    session = load_session(sessions[0])
    data = collect(session)
    stored = session.result.refit["parameters"]["joint_offset"]
    got = {p.name.split(".")[1]: p.value for p in data.fit.parameters}
    assert np.allclose([got[a] for a in "xyz"], [stored[a] for a in "xyz"], atol=1e-6)


def test_a_record_issued_again_with_other_content_is_a_revision(sessions, tmp_path):
    """ISO/IEC 17025:2017 7.8.8: ``report S`` then ``report S --after V`` into one folder
    give the same record id with other content: the second is revision 2, naming the
    issue it replaces and what changed; issuing the same content again is no revision."""
    calibration, validation = (load_session(path) for path in sessions)
    out = tmp_path / "report"
    record_file = out / "record.json"
    issue_report(calibration, out)
    first = record_file.read_bytes()
    assert json.loads(first)["revision"] == 1 and "revises" not in json.loads(first)
    issue_report(calibration, out)  # the same content: the same issue
    assert record_file.read_bytes() == first

    issue_report(calibration, out, validation=validation)
    second = json.loads(record_file.read_text())
    assert second["id"] == json.loads(first)["id"] and second["revision"] == 2
    assert second["revises"] == {"revision": 1, "issued": json.loads(first)["issued"],
                                 "sha256": hashlib.sha256(first).hexdigest()}
    assert "added validation_session" in second["changes"]
    assert "added validation_results" in second["changes"]
    assert "changed acceptance.as_left" in second["changes"]
    text = _text((out / "report.html").read_text(encoding="utf-8"))
    assert f"Calibration record {second['id']} revision 2" in text
    assert f"replaces revision 1 issued {json.loads(first)['issued']}" in text
    assert "changed since revision 1 changed acceptance.as_left added validation_session" \
        in text

    issue_report(calibration, out, validation=validation)
    assert json.loads(record_file.read_text()) == second  # no revision 3 for nothing
    issue_report(calibration, out)  # back to the first content: a new issue
    assert json.loads(record_file.read_text())["revision"] == 3


def test_calibrate_s_record_issued_again_keeps_the_maps_it_wrote(sessions, tmp_path):
    """``ogacq report S --after V --pdf`` into ``ogacq calibrate``'s report folder (it
    prints no PDF) re-issues its record: the maps the procedure wrote stay in it (only
    the procedure knows them); it issued revision 2 saying "removed compensation".
    With another validation session they are not carried (their figures are not its)."""
    calibration, validation = (load_session(path) for path in sessions)
    out = tmp_path / "report"
    compensation = {"procedure": "C-20261128-abcdef", "outcome": "validated",
                    "maps": {"x": {"source": "encoder scale +408 ± 35 ppm (k = 2)",
                                   "checksum": "2138"}}}
    record = build_record(calibration, validation=validation, compensation=compensation)
    issue_report(calibration, out, validation=validation, record=record)
    first = (out / "record.json").read_bytes()
    issue_report(calibration, out, validation=validation)  # what report does
    again = json.loads((out / "record.json").read_text())
    assert again["compensation"] == compensation
    assert (out / "record.json").read_bytes() == first  # the same content: no revision
    assert "Error maps (ogacq calibrate C-20261128-abcdef)" in _text(
        (out / "report.html").read_text(encoding="utf-8"))
    issue_report(calibration, out)  # without the validation: not its figures
    third = json.loads((out / "record.json").read_text())
    assert "compensation" not in third and "removed compensation" in third["changes"]


SCALE_X = {"x": {
    "instrument": {"gauge": "scale_x", "make": "Mitutoyo", "model": "AT715", "serial": "AT-42",
                   "certificate": "C-9", "calibrated": None, "due": None,
                   "uncertainty_mm": 0.002, "uncertainty_k": 2.0, "resolution_mm": 0.001,
                   "expired": None},
    "before": {"session": {"path": "/p/positioning-before-x.jsonl", "sha256": "ab",
                           "records": 130}, "targets": 31, "runs": 2,
               "iso230_2": {"A_mm": 0.0123, "B_mm": 0.0011, "R_mm": 0.0021, "E_mm": 0.0085,
                            "M_mm": 0.0079}},
    "found": {"flat": False, "pitch_mm": 5.001, "pitch_std_mm": 0.002,
              "amplitude_mm": 0.0041},
    "after": {"session": {"path": "/p/positioning-after-x.jsonl", "sha256": "cd",
                          "records": 130}, "targets": 31, "runs": 2,
              "iso230_2": {"A_mm": 0.0031, "B_mm": 0.001, "R_mm": 0.002, "E_mm": 0.0012,
                           "M_mm": 0.0011}},
    "validation": {"shown": True, "within": 31, "targets": 31, "worse": None}}}


def test_calibrate_s_record_issued_again_keeps_its_axis_scales_and_shows_them(sessions,
                                                                              tmp_path):
    """The scales' tests ``ogacq calibrate`` put in its record (``axis_scales``) stay in
    it when ``ogacq report`` issues it again into its folder, and its page shows a
    table per axis: the figures before and after in µm, the verdict, the scale."""
    calibration, validation = (load_session(path) for path in sessions)
    out = tmp_path / "report"
    record = {**build_record(calibration, validation=validation,
                             compensation={"procedure": "C-1", "outcome": "validated"}),
              "axis_scales": SCALE_X}
    issue_report(calibration, out, validation=validation, record=record)
    first = (out / "record.json").read_bytes()
    issue_report(calibration, out, validation=validation)  # what report does
    assert json.loads(first)["axis_scales"] == SCALE_X
    assert (out / "record.json").read_bytes() == first  # kept: no revision
    html = (out / "report.html").read_text(encoding="utf-8")
    text = _text(html).replace("&#39;", "'")
    assert "Positioning of each actuator by its axis scale (ISO 230-2:2014)" in text
    assert "shown: 31 of 31 targets within the map's U and the test's own" in text
    assert "a cyclic error of pitch 5.0010 ± 0.0040 mm (k = 2), amplitude 4.10 µm" in text
    assert _row_numbers(html, "before the write")[:5] == [12.3, 1.1, 2.1, 8.5, 7.9]
    assert _row_numbers(html, "after the write")[:5] == [3.1, 1.0, 2.0, 1.2, 1.1]
    assert "AT-42" in text and "C-9" in text
