"""``ogacq calibrate --simulator`` end to end, through the real drivers.

A squareness (which no table corrects: it stays, named) and an encoder scale (which
a map corrects): the procedure ends with the offsets and the map written, a
validation within the noise, the record as found and as left with the ISO 230-2
figures before and after. Killed at two points, it resumes to the same end. A write
made worse on purpose (the map's sign turned) is restored by the procedure itself,
and the history says so.
A lead screw's periodic error beside the squareness: the scan maps it, the map is
written and the validation finds it gone.
"""

from __future__ import annotations

import dataclasses
import json
import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from ogacq.calibration import procedure
from ogacq.cli.app import main
from ogacq.history.location import parse_location
from ogacq.history.states import timeline
from ogacq.history.store import History
from ogacq.model.axis_map import AxisMap
from ogacq.session.records import CalibrateRecord, OffsetsRecord
from ogacq.session.store import load_session
from ogacq.writeback.maps_table import maps_checksum, read_maps_table

SCALE_PPM = 400.0
EFFECTS = f"[squareness]\nxy = 0.5\n[encoder_scale]\nx = {SCALE_PPM}\n"
SEED = "3"
# A validation is judged at the 1 % level: one run in a hundred of a machine put right is
# called "improved" (kept, not within the noise at 1 %). What holds on every run: kept,
# and within the noise at 1e-6 (a correction that did not work leaves p far below: the
# campaigns before it fit with p < 1e-10). A map is "not shown" (kept) where the
# validation's gauges see its joint too little to tell it wrong (ogacq.calibration.sight).
KEPT = ("validated", "not shown", "improved")


def within_noise(verdict: dict) -> bool:
    return verdict["p_value"] is not None and verdict["p_value"] > 1e-6

FAST = ("--speed", "50", "--scan-step-mm", "20", "--yes")


def effects_file(folder: Path, text: str = EFFECTS) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / "effects.toml"
    path.write_text(text)
    return path


def log_steps(folder: Path) -> list[CalibrateRecord]:
    return load_session(folder / "procedure.jsonl").of_type(CalibrateRecord)


def step(folder: Path, name: str, **match) -> dict:
    found = [r.details for r in log_steps(folder) if r.step == name
             and all(r.details.get(k) == v for k, v in match.items())]
    assert found, f"no {name} {match} in the log"
    return found[-1]


def calibrated(root: Path, args: list[str]) -> Path:
    """``ogacq calibrate ARGS --out ROOT/cal``, ended with exit 0: its folder.

    The write is refused when the diagnosis's model is not within the noise at the 1 %
    level, which a correct model's campaign is once in a hundred (its timing moves the
    readings; seen once, p = 0.004), or when a reading lies far from its repeats at that
    level (seen once under load, p = 0.0004): such a refusal alone gets one more
    campaign, as does a separating scan judged not within the noise by chance alone
    (``scan_judged_by_chance``): this fails on them once in ten thousand runs, and on
    anything else at once."""
    for attempt in ("cal", "cal-again"):
        folder = root / attempt
        code = main(["calibrate", *args, "--out", str(folder)])
        if not ((code == 4 and refused_by_chance(folder)) or scan_judged_by_chance(folder)):
            break
    assert code == 0
    return folder


def scan_judged_by_chance(folder: Path, role: str = "separating") -> bool:
    """The separating scan's diagnosis (or another ``role``'s) not within the noise at
    the 1 % level, yet far from what a model left wrong gives (p > 1e-6): once in a
    hundred runs of a right model (seen under load, p = 0.0116 with the timing's
    readings), and then its maps are not established, the offsets alone written."""
    scans = [r.details for r in log_steps(folder) if r.step == "diagnosis"
             and r.details.get("role") == role]
    if not scans:
        return False
    final = scans[-1]["diagnosis"].get("chi2", {}).get("final", {})
    return final.get("consistent") is False and (final.get("p") or 0.0) > 1e-6


def refused_by_chance(folder: Path) -> bool:
    """The procedure refused the write for a test at its level alone: the verdict, or a
    reading named far from its repeats."""
    refused = [r.details for r in log_steps(folder) if r.step == "refused"]
    return bool(refused) and set(refused[-1].get("codes") or ()) <= {"inconsistent",
                                                                     "outlier"} \
        and bool(refused[-1].get("codes"))


def scan_rejected_by_chance(folder: Path) -> bool:
    """The separating scan's final model rejected at the 1 % level, yet far from what
    a model left wrong gives (p > 1e-6): the maps then not established, the offsets
    alone written (seen once in the CI command under load, the scan killed and
    resumed: p = 0.0015)."""
    finals = [r.details["diagnosis"]["chi2"]["final"] for r in log_steps(folder)
              if r.step == "diagnosis" and r.details.get("role") == "separating"]
    return bool(finals) and not finals[-1]["consistent"] and (finals[-1]["p"] or 0.0) > 1e-6


@pytest.fixture(scope="module")
def straight(tmp_path_factory) -> Path:
    """One uninterrupted calibration, in this process."""
    root = tmp_path_factory.mktemp("straight")
    return calibrated(root, ["--simulator", "--effects", str(effects_file(root)),
                             "--seed", SEED, *FAST])


def test_ends_validated_with_the_map_the_offsets_and_the_record(straight):
    finished = step(straight, "finished")
    assert finished["outcome"] in KEPT, finished
    # ambiguous from three positions per leg: the scan was planned with its duration, run
    separation = step(straight, "separation")
    assert separation["kind"] == "scan" and separation["run"]
    assert separation["duration_s"] > 0 and separation["reading_steps"] > 50
    # the map of x: the encoder scale, as the scan's diagnosis found it
    comp = step(straight, "compensation")
    assert comp["compensated"] == ["encoder_scale.x"]
    assert comp["uncompensated"] == ["squareness.xy"]
    maps = read_maps_table(straight / "maps.json").maps
    (m,) = maps.values()
    slope = (m.error_mm(50.0, 1) - m.error_mm(-50.0, 1)) / 100.0 * 1e6
    u = m.u_forward_mm[0] / 100.0 * 1e6  # at -100 mm: |q| u_s
    assert abs(slope - SCALE_PPM) < 3 * u + 10, (slope, u)
    # the offsets written and read back, audited in the calibration campaign's session
    stages = [r.stage for r in load_session(straight / "calibration.jsonl")
              .of_type(OffsetsRecord)]
    assert stages == ["intent", "done"]
    # every table with its figures beside it
    for name in ("linuxcnc/x.comp", "linuxcnc/linuxcnc.ini", "fanuc/fanuc.txt",
                 "siemens/AX_EEC.INI", "csv/compensation.csv"):
        assert (straight / "tables" / name).is_file(), name
    assert not (straight / "tables" / "NOT-APPLIED.txt").exists()  # applied: no warning
    # the validation: within the noise, offsets left near zero, the scale's error gone
    validation = step(straight, "validation", role="validation")
    assert within_noise(validation["verdict"]), validation["verdict"]
    assert all(abs(v) < 0.008 for v in validation["offsets_after_mm"].values())
    # the record: as found and as left, the ISO 230-2 figures before and after
    record = json.loads((straight / "report" / "record.json").read_text())
    assert record["acceptance"]["as_found"]["decision"] != "not evaluated"
    assert record["acceptance"]["as_left"]["decision"] != "not evaluated"
    iso = record["compensation"]["iso230_2"]
    before, after = iso["before"]["x"], iso["after"]["x"]
    # before: the scale over the 160 mm scanned (64 um), less the scan's noise
    assert before["E_mm"] > 0.04, before
    # after: the scale the papers' validation finds left is zero within its std (about
    # 30 ppm from three postures a leg: E after is up to 15 um at 3 std, so no fixed
    # fraction of E before holds on every run), and E after is that scale's
    left = validation["residual_effects"]["encoder_scale.x"]
    assert abs(left["value"]) < 5 * left["std"], left
    # the figures after are the scan's between the separating scan's targets (positions
    # the map was not identified from), where it has them: its scale left, over its span
    between = step(straight, "validation", role="validation-scan")
    left = between["residual_effects"]["encoder_scale.x"]
    assert abs(left["value"]) < 5 * left["std"], left
    span_mm = after["range_mm"][1] - after["range_mm"][0]
    assert after["E_mm"] == pytest.approx(abs(left["value"]) * 1e-6 * span_mm, abs=2e-6), after
    # with the drive's step beside it: a target is a whole count (10 um on CiA 402)
    assert after["drive_step_mm"] == 0.01
    assert after["E_with_step_mm"] == pytest.approx(after["E_mm"] + 0.01)
    if finished["outcome"] == "validated":  # it says where it looked
        assert "between them not measured" in finished["reason"], finished["reason"]
    assert record["writeback"] and record["compensation"]["outcome"] in KEPT
    # the page: the diagnosis the procedure made of the calibration campaign (it said
    # "no diagnosis was given") and the maps written beside the offsets
    page = (straight / "report" / "report.html").read_text()
    assert "no diagnosis was given" not in page and "squareness.xy" in page
    assert "Error maps (ogacq calibrate" in page


def test_killed_at_two_points_it_resumes_to_the_same_end(straight, tmp_path):
    folder = tmp_path / "cal"
    effects = effects_file(tmp_path)
    args = ["calibrate", "--simulator", "--effects", str(effects), "--seed", SEED,
            "--out", str(folder), *FAST, "--history", "none"]

    def readings(name: str) -> int:
        path = folder / name
        return path.read_text().count('"type":"reading"') if path.is_file() else 0

    # killed in the scan, then in the validation (after the write)
    for when in (lambda: readings("separating.jsonl") >= 40,
                 lambda: readings("validation.jsonl") >= 16):
        run = subprocess.Popen([sys.executable, "-m", "ogacq", *args],
                               stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        deadline = time.monotonic() + 240
        while not when() and run.poll() is None and time.monotonic() < deadline:
            time.sleep(0.05)
        if run.poll() is not None and refused_by_chance(folder):
            pytest.skip("the write was refused: the model not within the noise at the 1 % "
                        "level (a correct campaign's once in a hundred); no kill after it")
        assert run.poll() is None, "the procedure ended before the kill point"
        os.kill(run.pid, signal.SIGKILL)
        run.wait()
        args = ["calibrate", "--resume", str(folder), "--yes", "--history", "none"]
    done = subprocess.run([sys.executable, "-m", "ogacq", *args], capture_output=True,
                          text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    assert step(folder, "finished")["outcome"] in KEPT
    assert sum(r.step == "written" for r in log_steps(folder)) == 1  # written once
    # the same end: the same offsets (the register's step) and the same map (its u)
    for a, v in step(straight, "compensation")["offsets_mm"].items():
        assert abs(step(folder, "compensation")["offsets_mm"][a] - v) < 0.003, a
    if scan_rejected_by_chance(folder):
        pytest.skip("the resumed scan's model not within the noise at the 1 % level by "
                    "chance: no map to compare")
    ours = read_maps_table(folder / "maps.json").maps["x"]
    theirs = read_maps_table(straight / "maps.json").maps["x"]
    q = np.asarray(theirs.positions_mm)
    tolerance = 3 * np.hypot(ours.u_forward_mm, theirs.u_forward_mm) + 1e-4
    assert np.all(np.abs(ours.error_mm(q, 1) - theirs.error_mm(q, 1)) <= tolerance)


def test_a_write_made_worse_is_restored_by_calibrate_itself(tmp_path, monkeypatch, capsys):
    monkeypatch.setenv("COLUMNS", "250")  # its end wraps at the terminal's width
    made = procedure.compensation_of

    def wrong_sign(*args, **kwargs):
        comp = made(*args, **kwargs)
        flipped = {a: AxisMap(m.axis, m.positions_mm, tuple(-v for v in m.forward_mm),
                              tuple(-v for v in m.reverse_mm), m.u_forward_mm,
                              m.u_reverse_mm, m.reference_mm, "sign turned on purpose")
                   for a, m in comp.maps.items()}
        return dataclasses.replace(comp, maps=flipped)

    monkeypatch.setattr(procedure, "compensation_of", wrong_sign)
    for attempt in ("cal", "cal-again"):  # a refusal by chance alone: once more
        folder, history = tmp_path / attempt, tmp_path / f"{attempt}.sqlite"
        capsys.readouterr()
        code = main(["calibrate", "--simulator", "--effects", str(effects_file(tmp_path)),
                     "--seed", SEED, "--out", str(folder), *FAST, "--no-separate",
                     "--history", str(history)])
        if not (code == 4 and refused_by_chance(folder)):
            break
    assert code == 4  # restored: refused as unsafe
    end = capsys.readouterr().err
    assert re.search(r"^record: OGQ-\d{8}-[0-9a-f]{8} \(", end, re.M), end
    assert f"next: ogacq diagnose {folder / 'calibration.jsonl'}" in end, end
    finished = step(folder, "finished")
    assert finished["outcome"] == "restored" and "grew" in finished["reason"]
    restored = step(folder, "restored")
    assert restored["maps"] and restored["offsets"]
    assert read_maps_table(folder / "maps.json").checksum == maps_checksum({})
    with History.open(parse_location(str(history), "--history"), create=False) as db:
        machine = db.find_machine("Orthoglide prototype")
        states = timeline(db.states(machine), db.map_states(machine),
                          db.calibrate_events(machine))
    fates = [v.fate or "" for v in states]
    assert any(f.startswith("restored by calibrate") and "grew" in f for f in fates), fates
    assert any(f.startswith("restore by calibrate") for f in fates), fates
    assert states[-1].maps == {}  # the maps state the restore left: none
    # the tables of the maps restored stay as evidence, marked for no one to load them
    marker = folder / "tables" / "NOT-APPLIED.txt"
    assert "ended restored" in marker.read_text() and "Do not load them" in marker.read_text()
    assert f"the tables in {folder / 'tables'} were not applied" in end


def test_an_effects_file_that_does_not_load_is_refused_before_the_folder(tmp_path, capsys):
    """Named as given, nothing started: it was copied into the folder first, the error
    named the copy, and the same command with the file corrected 'continued' with the
    copy, failing again (found by the records34 audit)."""
    bad = tmp_path / "bad.toml"
    bad.write_text("garbage[\n")
    folder = tmp_path / "run"
    assert main(["calibrate", "--simulator", "--effects", str(bad), "--out", str(folder),
                 "--yes", "--history", "none"]) == 2
    assert f"{bad}:1: not valid TOML" in capsys.readouterr().err
    assert not (folder / "procedure.jsonl").exists()


def test_maps_shown_and_restored_by_hand(straight, capsys, monkeypatch):
    """After the procedure (last: it changes the straight run's maps file)."""
    session = straight / "calibration.jsonl"
    monkeypatch.setattr(sys, "stdin", __import__("io").StringIO(""))
    assert main(["maps", "show", str(session)]) == 0
    assert "ISO 230-2" in capsys.readouterr().out
    assert main(["maps", "restore", str(session)]) == 1  # declined: nothing restored
    assert "x" in read_maps_table(straight / "maps.json").maps
    assert main(["maps", "restore", str(session), "--yes", "--history", "none"]) == 0
    assert read_maps_table(straight / "maps.json").maps == {}


def test_a_cyclic_screw_error_is_mapped_and_not_shown_beyond_where_it_is_seen(tmp_path):
    """Squareness and a lead screw's periodic error (8 um, 20 mm pitch; the seed's x
    offset 1.24 mm): the scan (every 5 mm: four readings a period) maps the screw, the
    map is written with the offsets, moved with them, and both validations find it gone,
    the squareness left as it is. A map left where the campaign's coordinate had it
    (the screw 1.24 mm off under it) left 6 of 16 um and was not within the noise.
    The validation sees the x joint along its line only over the 16 mm it moves while
    the other legs are driven: beyond, an error of the map's size would pass its test,
    so the map is kept "not shown" (it said "validated")."""
    text = "[squareness]\nxy = 0.5\n[lead_screw.x]\namplitude_mm = 0.008\npitch_mm = 20.0\n"
    folder = calibrated(tmp_path, ["--simulator", "--effects", str(effects_file(tmp_path, text)),
                                   "--seed", SEED, "--speed", "50", "--scan-step-mm", "5",
                                   "--yes", "--history", "none"])
    finished = step(folder, "finished")
    # "improved" where a validation was not within the noise at the 1 % level, once in
    # a hundred runs of a machine put right (seen under load): kept, and said so before
    # what it shows (within_noise below holds it to chance)
    assert finished["outcome"] in ("not shown", "improved"), finished
    if finished["outcome"] == "not shown":
        # the stretch seen directly grows as the readings' noise falls: -11 to +7 mm at
        # 1 um, -29 to +7 mm at 0.2 um; a mode of the map found off beyond chance is said
        # first (seen twice under load: "finds its phase found off beyond chance ... and")
        assert "the x correction (" in finished["reason"] and re.search(
            r"is not shown: the validation (finds its .+ beyond chance .+ and )?sees an "
            r"error of its size only over q from -\d+ to \+\d+ mm", finished["reason"]), \
            finished["reason"]
    for role in ("validation", "validation-scan"):
        verdict = step(folder, "validation", role=role)["verdict"]
        assert within_noise(verdict), (role, verdict)
    comp = step(folder, "compensation")
    assert comp["diagnosis_maps"] and comp["uncompensated"] == ["squareness.xy"]
    # the map in the coordinate of the offsets written: moved by their change, zero at
    # q = 0, over the whole travel
    m = read_maps_table(folder / "maps.json").maps["x"]
    assert m.extra["moved_with_offsets_mm"] == pytest.approx(comp["offsets_mm"]["x"], abs=0.006)
    assert m.reference_mm == 0.0 and m.positions_mm[0] <= -100.0 <= 60.0 <= m.positions_mm[-1]
    record = json.loads((folder / "report" / "record.json").read_text())
    before = record["compensation"]["iso230_2"]["before"]["x"]
    after = record["compensation"]["iso230_2"]["after"]["x"]
    # what the map left, fitted again on the validation scan: within its band
    assert after["E_mm"] < before["E_mm"] / 4, (before["E_mm"], after["E_mm"])
    assert after["E_mm"] <= 2 * 3 * after["u_max_mm"] + 1e-4, after
