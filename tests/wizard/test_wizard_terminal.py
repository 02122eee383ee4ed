"""The real ``ogacq wizard --simulator`` driven in a pseudo-terminal, keys and Ctrl-C
included: a full calibration, a gauge that goes silent, a pause then quit and
``ogacq resume``, and dial indicators read by eye."""

from __future__ import annotations

import json
import re
import subprocess
import sys

import pytest

from ogacq.campaign.campaign_file import read_campaign
from ogacq.io.machine_file import read_machine
from ogacq.record.context import calibration_context
from ogacq.session.records import EndRecord, FaultRecord, OffsetsRecord, OperatorRecord
from ogacq.session.store import load_session
from tests.wizard.terminal import SHOWN, Wizard

pytestmark = pytest.mark.slow


@pytest.fixture
def wizards():
    started: list[Wizard] = []
    yield started
    for wizard in started:
        wizard.close()


def start(wizards, folder, *args: str, resume=None) -> Wizard:
    wizard = Wizard(folder, *args, resume=resume)
    wizards.append(wizard)
    return wizard


def test_full_guided_calibration_to_a_result(tmp_path, wizards):
    w = start(wizards, tmp_path / "run")
    w.expect(r"Ports found")
    w.expect(r"simulated gauge y_x")
    w.connect_with_defaults()
    w.measure_in_place(24)  # six left in place: one stop at the start, none per leg
    # Ctrl-C at the last question: a pause, then the question again (it went on to the
    # result with the temperature unrecorded)
    w.expect(r"Ambient temperature now, at the end, °C")
    w.ctrl_c()
    w.expect(r"Paused\S* after the last reading, before the result")
    w.answer(r"Resume or quit\?", "r")
    w.end_temperature("21,5")
    w.expect(r"Joint offsets identified from 72 readings \(mm\)")
    # each offset with its U (k = 2): two significant digits, the value at its place
    for joint in "xyz":
        row = w.expect(rf"{joint}\s+│\s+[+-]\d+\.(\d+)\s+│\s+\d\.(\d+)\s+│\s+[+-]\d+\.\d+")
        assert len(row.group(1)) == len(row.group(2))
    w.expect(r"Residual rms")
    w.expect(r"identifiable: every offset is determined")
    w.verdict()
    w.expect(r" \(.* test, combined p = ")
    # one confirmation, the write-back's own (it was asked twice: issue 38.3)
    w.answer(r"Write these offsets to the controller and re-home", "n")
    w.expect(r"Not written \(rehearsal")
    w.expect(r"ogacq offsets write SESSION")
    # the record offered, written; no validation offered (nothing was written)
    w.answer(r"Write the calibration record now", "y")
    record_id = w.expect(r"record (OGQ-\d{8}-[0-9a-f]{8}): ").group(1)
    w.expect(r"verdict: within the gauge noise")
    w.expect(rf"record: {record_id} \(issued as ")
    w.expect(r"next: open ")  # the path: folded where the screen ends (tmp paths are long)
    w.expect(r"a rehearsal: the simulated controller stops with the wizard")
    w.expect(r"Calibration campaign complete")
    assert w.finish() == 0
    transcript = "".join(w.transcript)
    assert "set the two gauges" not in transcript and "Run a validation" not in transcript
    # one unit on the result's screen: mm (no µm beside the offsets)
    result = transcript[transcript.index("Joint offsets identified"):]
    assert "µm" not in result[:result.index("Session:")]
    assert json.loads((tmp_path / "run" / "report" / "record.json").read_text())["id"] \
        == record_id

    session = load_session(w.session)
    assert session.finished and len(session.readings) == 72
    assert session.header.wizard["by_eye"] == []
    checked = [r for r in session.of_type(OperatorRecord) if r.action == "gauges_checked"]
    assert [r.details["leg"] for r in checked] == ["x", "y", "z"]
    truth = session.header.simulator
    assert truth["seed"] == 3
    # who, what and at what temperature, as answered (the offered values)
    context = calibration_context(session)
    assert context.machine_name == "Orthoglide prototype" and context.machine_serial is None
    assert context.instrument("y_x").serial == "sim-y_x"
    assert context.instrument("y_x").due is not None and not context.expired(
        context.instrument("y_x"))
    assert (context.environment.start.ambient_c, context.environment.end.ambient_c) == (
        20.0, 21.5)
    # the campaign file beside the session gives back the same plan (ogacq resume needs it)
    campaign = read_campaign(tmp_path / "run" / "campaign.toml")
    assert campaign.protocol.to_dict() == session.header.plan
    assert campaign.simulator is not None and campaign.simulator.seed == 3


def test_two_indicators_moved_from_leg_to_leg(tmp_path, wizards):
    """The papers' station: two indicators, one port each, set on every leg in turn."""
    w = start(wizards, tmp_path / "run", "--indicators", "2")
    w.expect(r"simulated indicator 1, moved from leg to leg: y_x, x_y, x_z")
    w.connect_with_defaults(indicators=2)
    for leg in "xyz":
        w.set_gauges(leg)
        w.expect(rf"{leg} leg measured: 24 readings")
    w.end_temperature()
    w.expect(r"Joint offsets identified from 72 readings")
    told = re.findall(r"Gauge ([xyz]_[xyz]) is the indicator on /dev/\S+: it goes from leg",
                      "".join(w.transcript))
    assert told == ["y_x", "z_x", "x_y", "z_y", "x_z", "y_z"]
    # the write-back, then the save offered (the profile can): declined, and said what
    # a power cycle then does before the job is called complete
    w.verdict()
    w.answer(r"Write these offsets to the controller and re-home", "y")
    w.answer(r"Save them to the drive's non-volatile memory too\?", "n")
    w.expect(r"not in the drive's non-volatile")
    w.answer(r"Write the calibration record now", "n")
    w.answer(r"Run a validation campaign now", "n")
    w.expect(r"Not run. Later, with the gauges in place")
    w.expect(r"Calibration campaign complete")
    assert w.finish() == 0

    session = load_session(w.session)
    assert session.finished and len(session.readings) == 72
    gauges = session.header.station["gauges"]
    assert gauges["y_x"]["port"] == gauges["x_y"]["port"] == gauges["x_z"]["port"]
    assert gauges["z_x"]["port"] == gauges["z_y"]["port"] == gauges["y_z"]["port"]
    assert gauges["y_x"]["port"] != gauges["z_x"]["port"]
    assert session.header.simulator["gauge_layout"] == "moved"
    campaign = read_campaign(tmp_path / "run" / "campaign.toml")  # what `ogacq resume` reads
    assert campaign.simulator is not None and campaign.simulator.gauge_layout == "moved"
    # each gauge was read on its own leg: the fit is consistent, the offsets sharp
    fit = session.result.refit
    assert max(fit["std"]["joint_offset"].values()) < 0.002
    assert fit["residual_rms_mm"] < 0.005


def test_silent_gauge_is_named_and_retry_continues(tmp_path, wizards):
    # z_x stops answering after 5 readings, for the runner's three attempts
    w = start(wizards, tmp_path / "run", "--cycles", "1", "--simulate-fault", "z_x:silence@5x3")
    w.connect_with_defaults()
    w.set_all_gauges()
    w.expect(r"Gauge z_x \(on the x leg, along z\) stopped answering", 20)
    w.expect(r"no reply")
    w.expect(r"retry")
    w.expect(r"read z_x by eye from now on")
    w.answer(r"What now\?", "r")
    w.expect(r"continues where it stopped")
    w.expect(r"x leg measured: 8 readings")
    for leg in "yz":
        w.still_set(leg)
    w.end_temperature()
    w.expect(r"Joint offsets identified from 24 readings")
    w.verdict()
    w.answer(r"Write these offsets", "n")
    # Ctrl-C at an offer after the result: a pause (it quit without a word); a quit
    # there still ends with the verdict, the record id and what is left to do
    w.expect(r"Write the calibration record now")
    w.ctrl_c()
    w.answer(r"Resume or quit\?", "q")
    w.expect(r"verdict: within the gauge noise")
    w.expect(r"record: OGQ-\d{8}-[0-9a-f]{8}")
    w.expect(r"next: ogacq report ")
    w.expect(r"Stopped here: the campaign is complete and saved")
    assert w.finish() == 130
    session = load_session(w.session)
    faults = session.of_type(FaultRecord)
    assert len(faults) == 3 and {f.gauge for f in faults} == {"z_x"}
    keys = [(r.step, r.gauge.key) for r in session.readings]
    assert len(keys) == len(set(keys)) == 24 and session.finished


def test_ctrl_c_pauses_resumes_then_quits_and_ogacq_resume_completes(tmp_path, wizards):
    w = start(wizards, tmp_path / "run", "--cycles", "1", "--indicators", "2")
    w.connect_with_defaults(indicators=2)
    w.set_gauges("x")
    w.expect(r"x leg")  # the cycles are running
    w.ctrl_c()
    w.expect(r"Paused")
    w.expect(r"after reading \d+ of 24")
    w.expect(r"The axes hold their position")
    w.answer(r"Resume or quit\?", "r")
    w.expect(r"Resuming")
    w.expect(r"x leg measured: 8 readings")
    w.expect(r"Leg y: set the two gauges")
    w.expect(r"mid-range")
    w.ctrl_c()
    w.expect(r"Paused")
    w.expect(r"while setting the gauges of the y leg")
    w.answer(r"Resume or quit\?", "q")
    w.expect(r"Stopped after 8 readings")
    w.expect(r"ogacq resume ")
    assert w.finish() == 130

    session = load_session(w.session)
    assert not session.finished and len(session.readings) == 8
    assert session.of_type(EndRecord)[-1].status == "interrupted"
    resumed = subprocess.run([sys.executable, "-m", "ogacq", "resume", str(w.session)],
                             capture_output=True, text=True, timeout=60)
    assert resumed.returncode == 0, resumed.stderr
    session = load_session(w.session)
    keys = [(r.step, r.gauge.key) for r in session.readings]
    assert session.finished and len(keys) == len(set(keys)) == 24


def test_a_rehearsal_quit_at_its_result_writes_and_validates_when_resumed(tmp_path, wizards):
    """Ctrl-C after the result, then `ogacq wizard --resume`: the write-back answered
    yes wrote nothing (the session's campaign file starts a simulator inside each
    command: exit 2) and named a command that failed the same way. Resumed, the
    rehearsal's simulator starts again, the write asks once, and the validation runs."""
    w = start(wizards, tmp_path / "run", "--cycles", "1")
    w.connect_with_defaults()
    w.measure_in_place(8)
    w.end_temperature()
    w.verdict()
    w.answer(r"Write these offsets to the controller and re-home", "n")
    w.expect(r"Write the calibration record now")
    w.ctrl_c()
    w.answer(r"Resume or quit\?", "q")
    assert w.finish() == 130

    again = start(wizards, tmp_path / "run", resume=w.session)
    again.verdict()
    again.answer(r"Write these offsets to the controller and re-home", "y")
    again.answer(r"Save them to the drive's non-volatile memory too\?", "n")
    again.answer(r"Write the calibration record now", "n")
    again.answer(r"Run a validation campaign now", "y")
    again.expect(r"Validation campaign, recorded in ")
    again.measure_in_place(8)
    again.end_temperature()
    again.expect(r"Offsets remaining after the write-back from 24 readings")
    again.expect(r"Calibration campaign complete")
    assert again.finish() == 0
    stages = [r.stage for r in load_session(w.session).of_type(OffsetsRecord)]
    assert stages == ["declined", "intent", "done"]


def test_dial_indicators_read_by_eye_out_of_range_refused_then_accepted(tmp_path, wizards):
    w = start(wizards, tmp_path / "run", "--cycles", "1", "--by-eye")
    w.connect_with_defaults(by_eye=True)  # with --by-eye, "by eye" is the default answer
    plan = next(line for line in "".join(w.transcript).splitlines() if "Plan:" in line)
    assert "24 readings, each typed by you" in plan and "automatically" not in plan
    for leg in "xyz":
        w.expect(rf"Leg {leg}: set the two gauges")
        for _ in range(2):  # each gauge's value as set: the reference of its readings
            w.type_what_is_shown(r"what does it show now \(mm\)\?")
        for k in range(8):
            w.expect(r"Reading \d+ of 24")
            expected = w.expect(r"Expected (-?\d+\.\d+) … (-?\d+\.\d+) mm")
            low, high = float(expected.group(1)), float(expected.group(2))
            if leg == "x" and k == 2:  # a misread: refused, with the range it is outside
                shown = w.expect(SHOWN).group(1)
                w.answer(r"reads \(mm\)", f"{high + 0.5:.3f}")
                w.expect(r"is outside the expected")
                w.expect(r"the same value typed twice is kept")
                w.answer(r"reads \(mm\)", shown)
                assert low <= float(shown) <= high
                continue
            assert low <= w.type_what_is_shown(r"reads \(mm\)") <= high
    w.end_temperature()
    w.expect(r"Joint offsets identified from 24 readings")
    w.expect(r"identifiable: every offset is determined")
    w.verdict()
    w.answer(r"Write these offsets", "n")
    w.answer(r"Write the calibration record now", "n")
    assert w.finish() == 0
    session = load_session(w.session)
    assert session.finished
    assert set(session.header.wizard["by_eye"]) == {"y_x", "z_x", "x_y", "z_y", "x_z", "y_z"}
    assert all(r.raw.startswith("typed ") and "kept" not in r.raw
               for r in session.readings)


def test_by_eye_session_quit_at_a_reading_continues_with_wizard_resume(tmp_path, wizards):
    w = start(wizards, tmp_path / "run", "--cycles", "1", "--by-eye")
    w.connect_with_defaults(by_eye=True)
    for _ in range(2):
        w.type_what_is_shown(r"what does it show now \(mm\)\?")
    for _ in range(3):
        w.type_what_is_shown(r"reads \(mm\)")
    w.expect(r"Reading 4 of 24")
    w.expect(r"reads \(mm\)")
    w.ctrl_c()
    w.expect(r"at reading 4 of 24")
    w.answer(r"Resume or quit\?", "q")
    w.expect(r"Stopped after 3 readings")
    w.expect(r"ogacq wizard --resume ")
    assert w.finish() == 130
    # `ogacq resume` cannot ask for typed values: it says which command can
    refused = subprocess.run([sys.executable, "-m", "ogacq", "resume", str(w.session)],
                             capture_output=True, text=True, timeout=60)
    assert refused.returncode == 2
    assert "read by eye: continue with `ogacq wizard --resume" in refused.stderr
    assert len(load_session(w.session).readings) == 3  # nothing touched

    again = start(wizards, tmp_path / "run", resume=w.session)
    again.expect(r"3 readings recorded")
    again.expect(r"controller answers")
    for _ in range(5):  # the x leg goes on from its 4th reading: its gauges stay set
        again.expect(r"Reading \d+ of 24")
        again.type_what_is_shown(r"reads \(mm\)")
    for _ in "yz":
        for _ in range(2):
            again.type_what_is_shown(r"what does it show now \(mm\)\?")
        for _ in range(8):
            again.type_what_is_shown(r"reads \(mm\)")
    again.end_temperature()
    again.expect(r"Joint offsets identified from 24 readings")
    again.verdict()
    again.answer(r"Write these offsets", "n")
    again.answer(r"Write the calibration record now", "n")
    assert again.finish() == 0
    session = load_session(w.session)
    keys = [(r.step, r.gauge.key) for r in session.readings]
    assert session.finished and len(keys) == len(set(keys)) == 24


def test_rtu_rehearsal_edges_then_not_started_leaves_no_folder(tmp_path, wizards):
    """An RTU controller's baud rate is asked; --indicators 6 is not asked again; after
    "change the port" the detected port is still offered; a cause said once; declining
    to start names the full command and leaves no folder behind."""
    folder = tmp_path / "run"
    w = start(wizards, folder, "--profile", "iai-pcon", "--indicators", "6")
    w.answer(r"Register map of the controller")
    controller = w.expect(r"Controller port.*?(/dev/pts/\d+)").group(1)
    w.child.sendline("")
    w.answer(r"Baud rate of the controller's serial line .*38400")
    w.expect(r"controller answers")
    w.answer(r"How are the gauges read\?")
    offered = w.expect(r"Gauge y_x \(on the x leg, along y\).*?(/dev/pts/\d+)").group(1)
    assert offered != controller
    w.child.sendline(controller)  # one port, one device: the controller's is refused
    w.expect(rf"{controller} is the controller's port already: one port, one device")
    w.expect(r"Gauge y_x \(on the x leg, along y\)")
    w.child.sendline("/dev/ttyNOPE")
    w.expect(r"Check the cable")
    problem = " ".join(w.transcript[-1].split()).partition("did not give a value:")[2]
    assert problem.count("ttyNOPE") == 1 and "Errno" not in problem, problem
    w.answer(r"What now\?", "c")
    assert w.expect(r"Gauge y_x \(on the x leg, along y\).*?(/dev/pts/\d+)").group(1) == offered
    w.child.sendline("")
    w.expect(r"y_x reads [0-9.]+ mm")
    for gauge in ("z_x", "x_y", "z_y", "x_z", "y_z"):
        w.answer(rf"Gauge {gauge} \(on the")
        w.expect(rf"{gauge} reads [0-9.]+ mm")
    w.answer(r"Is this the machine you are calibrating\?")
    w.identify_with_defaults(6)
    w.expect(r"72 readings, taken automatically")
    w.answer(r"Start\?", "n")
    w.expect(r"Start again with: ogacq wizard --simulator --indicators 6 --out ")
    assert w.finish() == 130
    transcript = "".join(w.transcript)
    assert "How many indicators" not in transcript
    assert not folder.exists()


def test_quit_at_the_first_question_names_the_rehearsal_command(tmp_path, wizards):
    folder = tmp_path / "run"
    w = start(wizards, folder)
    w.expect(r"Register map of the controller")
    w.ctrl_c()
    w.answer(r"Resume or quit\?", "q")
    w.expect(r"Nothing was measured. Start again with: ogacq wizard --simulator --out ")
    assert w.finish() == 130
    assert not folder.exists()


def test_a_new_expired_gauge_is_refused_until_a_reason_is_given(tmp_path, wizards):
    """A gauge typed in for the first time with a certificate already past due: the
    wizard says so before anything moves; the reason given is recorded and the gauge
    is remembered in the inventory. Ctrl-C at a question loses no answer given."""
    w = start(wizards, tmp_path / "run", "--cycles", "1", "--indicators", "6")
    w.answer(r"Register map of the controller")
    w.answer(r"Controller port")
    w.answer(r"How are the gauges read\?")
    for gauge in ("y_x", "z_x", "x_y", "z_y", "x_z", "y_z"):
        w.answer(rf"Gauge {gauge} \(on the")
    w.answer(r"Is this the machine you are calibrating\?")
    w.answer(r"Machine name", "OG-1 cell 3")
    w.answer(r"Machine serial number", "OG-2026-0017")
    # Ctrl-C at a question, then resume: the questions come again, each answer given
    # before the pause offered (Enter keeps it), none lost
    w.expect(r"Operator \(your name\)")
    w.ctrl_c()
    w.answer(r"Resume or quit\?", "r")
    w.expect(r"answers given before the pause are offered again")
    w.answer(r"Machine name .{0,20}OG-1 cell 3")
    w.answer(r"Machine serial number .{0,20}OG-2026-0017")
    w.answer(r"Operator \(your name\)", "J. Martin")
    w.answer(r"Ambient temperature now, °C", "twenty")  # refused in words
    w.expect(r"'twenty' is not a number: type a temperature in °C")
    w.answer(r"Ambient temperature now, °C", "22,5")
    w.answer(r"Serial number of gauge y_x", "12345678")
    w.expect(r"12345678 is new")
    for prompt, text in ((r"Make", "Mitutoyo"), (r"Model", "543-790B"),
                         (r"certificate number", "DKD-K-12345"),
                         (r"Calibrated on", "2024-01-10"), (r"Calibration due", "2024/12"),
                         (r"Calibration due", "2025-01-10"),
                         (r"expanded uncertainty U", "0.0015"), (r"coverage factor k", "")):
        w.answer(prompt, text)
    # shown whole and confirmed before instruments.toml keeps it
    w.expect(r"12345678: Mitutoyo 543-790B, certificate DKD-K-12345, calibrated 2024-01-10, "
             r"due 2025-01-10, U = 0.0015 mm \(k = 2\)")
    w.answer(r"Is this right\?", "y")
    for _ in range(5):
        w.answer(r"Serial number of gauge")
    w.expect(r"Gauge y_x \(serial 12345678, due 2025-01-10\) is past the due date")
    w.answer(r"What now\?", "o")
    w.answer(r"Why measure with a gauge past its due date\?", "compared with gauge blocks")
    w.answer(r"Start\?")
    w.measure_in_place(8)
    w.end_temperature("23")
    # written, the record issued, then the validation the wizard offers: the same plan
    # into session-2.jsonl, one stop to check the six gauges, what remains of the
    # offsets, and the record issued again as found and as left (its revision 2)
    w.verdict()
    w.answer(r"Write these offsets to the controller and re-home", "y")
    w.answer(r"Save them to the drive's non-volatile memory too\?", "n")
    w.answer(r"Write the calibration record now", "y")
    w.expect(r"record OGQ-\d{8}-[0-9a-f]{8}: ")
    w.answer(r"Run a validation campaign now", "y")
    # the folder's path is folded where the screen ends: session-2.jsonl is checked below
    w.expect(r"Validation campaign, recorded in ")
    w.measure_in_place(8)
    w.end_temperature("23")
    w.expect(r"Offsets remaining after the write-back from 24 readings")
    w.answer(r"Write the calibration record now \(as found and as left", "y")
    w.expect(r"record OGQ-\d{8}-[0-9a-f]{8} revision 2: ")
    # the end gives the validation's verdict beside the calibration's
    w.expect(r"verdict: ")
    w.expect(r"validation: (NOT )?within the gauge noise .*session-2\.jsonl")
    w.expect(r"next: open ")
    w.expect(r"\(the record as found and as left\)")
    w.expect(r"Calibration campaign complete")
    assert w.finish() == 0
    validation = load_session(tmp_path / "run" / "session-2.jsonl")
    assert validation.finished and len(validation.readings) == 24
    record = json.loads((tmp_path / "run" / "report" / "record.json").read_text())
    assert record["revision"] == 2 and "added validation_session" in record["changes"]
    for axis, left in record["validation_results"]["joint_offset"].items():
        # what remains: the register's 0.01 mm step and the noise, not the offset
        assert abs(left["value_mm"]) < 0.02, (axis, left)
    session = load_session(w.session)
    context = calibration_context(session)
    assert (context.machine_name, context.machine_serial, context.operator) == (
        "OG-1 cell 3", "OG-2026-0017", "J. Martin")
    # the identity answered, into the machine file the wizard wrote in its folder, said:
    # a later campaign of that file is the same machine in the history (issue 38.1)
    machine = read_machine(tmp_path / "run" / "machine.toml")
    assert (machine.name, machine.serial) == ("OG-1 cell 3", "OG-2026-0017")
    assert "now names the machine 'OG-1 cell 3' serial OG-2026-0017" in " ".join(
        "".join(w.transcript).split())
    y_x = context.instrument("y_x")
    assert (y_x.make, y_x.certificate, y_x.uncertainty_mm, y_x.uncertainty_k) == (
        "Mitutoyo", "DKD-K-12345", 0.0015, 2.0)
    assert [(o.subject, o.reason, o.operator) for o in context.overrides] == [
        ("y_x 12345678", "compared with gauge blocks", "J. Martin")]
    assert (context.environment.start.ambient_c, context.environment.end.ambient_c) == (
        22.5, 23.0)
    inventory = (tmp_path / "ogacq-home" / "instruments.toml").read_text()
    assert 'serial = "12345678"' in inventory and "due = 2025-01-10" in inventory
    assert 'operator = "J. Martin"' in inventory
