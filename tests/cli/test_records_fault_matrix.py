"""Issue 26's fault matrix, a lean row each: what is recorded is whole and true.

One simulated campaign (module fixture) recorded by a machine named ``Cell [/3]``,
an operator ``J. [/x] Martin :x:`` (one with a terminal escape in the name is refused
where it is typed, issue 36.6), in a folder
``runs [/y]``; then, through the real commands: an edited session refused by every
analysis, a cut one said partial everywhere and kept out of the history, recorded
text printed as it is, malformed history URLs in one line, and the numbers of the
input fuzz refused. (A full and a read-only disk: test_disk_faults_26.py; diagnose
during a run: test_running_campaign.py; the sweeps with their counts:
bench/fuzz_sweep.py.)
"""

from __future__ import annotations

import json
import shutil
import sqlite3
from pathlib import Path

import pytest

from ogacq.cli.app import main
from tests.campaign.conftest import write_campaign
from tests.cli.helpers import on_read_only, run_ogacq, with_file_size_limit

MACHINE_NAME = "Cell [/3]"
OPERATOR = "J. [/x] Martin :x:"  # rich markup, an emoji code
OPERATOR_TOML = OPERATOR
OPERATOR_SHOWN = OPERATOR  # as every command prints it


@pytest.fixture(scope="module")
def recorded(tmp_path_factory) -> Path:
    """A finished simulated campaign in ``runs [/y]``, its history beside it."""
    folder = tmp_path_factory.mktemp("matrix") / "runs [/y]"
    path = write_campaign(folder, seed=3, speed=100, line_at_speed=True)
    machine = folder / "machine.toml"
    machine.write_text(f'name = "{MACHINE_NAME}"\nserial = "SN [b]"\n' + machine.read_text())
    path.write_text(f'operator = "{OPERATOR_TOML}"\n' + path.read_text())
    ran = run_ogacq("run", path, "--history", folder / "history.sqlite")
    assert ran.returncode == 0, ran.stderr  # the red team's run crashed here, exit 1
    assert "Traceback" not in ran.stderr and "\x1b" not in ran.stdout + ran.stderr
    assert str(folder / "session.jsonl") in " ".join(ran.stdout.split())
    return folder / "session.jsonl"


def test_an_operator_with_a_terminal_escape_is_refused_where_it_is_typed(tmp_path):
    """Issue 36.6: the name is refused in one line naming the character, before anything
    runs; it is never recorded, so no command has it to print."""
    path = write_campaign(tmp_path / "escape", seed=3, speed=100)
    path.write_text('operator = "J. Martin \\u001b[2J"\n' + path.read_text())
    ran = run_ogacq("run", path, "--history", "none")
    assert ran.returncode == 2, ran.stderr
    assert "U+001B" in one_line(ran.stderr) and "\x1b[2J" not in ran.stderr
    assert not (tmp_path / "escape" / "session.jsonl").exists()


def here(capsys, *args: object) -> tuple[int, str, str]:
    capsys.readouterr()
    code = main([str(a) for a in args])
    out = capsys.readouterr()
    return code, out.out, out.err


def one_line(err: str) -> str:
    # `ogacq report` says its work first, a line of its own (README), then any problem
    lines = [line for line in err.strip().splitlines()
             if not line.startswith("ogacq report: issuing the record of ")]
    assert len(lines) == 1 and "Traceback" not in err, err
    return lines[0]


def test_recorded_text_is_printed_as_it_is_by_every_command(recorded, capsys, tmp_path):
    history = recorded.parent / "history.sqlite"
    shown = {}
    for args in (["session", "show", recorded], ["session", "check", recorded],
                 ["history", MACHINE_NAME, "--history", history],
                 ["history", MACHINE_NAME, "--history", history, "--states"],
                 ["refit", recorded], ["diagnose", recorded, "--history", "none"],
                 ["report", recorded, "--out", tmp_path / "report"],
                 ["session", "export", recorded, tmp_path / "r.csv"],
                 ["offsets", "show", recorded]):
        code, out, err = here(capsys, *args)
        # offsets show: the simulator's campaign names no controller that outlives it
        assert code == (2 if args[0] == "offsets" else 0), (args, err)
        assert "\x1b" not in out + err, args
        shown.setdefault(" ".join(map(str, args[:2])), " ".join((out + err).split()))
    assert f"machine {MACHINE_NAME}, serial SN [b]; operator {OPERATOR_SHOWN}" in \
        shown["session show"]
    assert MACHINE_NAME in shown[f"history {MACHINE_NAME}"]
    # a table cell may wrap at a space: each part as recorded
    assert all(part in shown[f"history {MACHINE_NAME}"] for part in OPERATOR_SHOWN.split())
    assert str(recorded) in shown[f"refit {recorded}"]
    assert str(recorded) in shown[f"diagnose {recorded}"]
    record = json.loads((tmp_path / "report" / "record.json").read_text(encoding="utf-8"))
    assert record["operator"] == OPERATOR and record["session"]["integrity"] == "sealed"


def _edited_copy(recorded: Path, target: Path, line: int, delete=("crc",)) -> Path:
    lines = recorded.read_text().splitlines()
    record = json.loads(lines[line - 1])
    record["reading_mm"] = round(record["reading_mm"] + 0.05, 6)
    for key in delete:
        record.pop(key)
    lines[line - 1] = json.dumps(record, separators=(",", ":"))
    target.write_text("\n".join(lines) + "\n")
    return target


def test_an_edited_session_is_refused_by_every_analysis_unless_accepted(recorded, capsys,
                                                                        tmp_path):
    lines = recorded.read_text().splitlines()
    readings = [k for k, line in enumerate(lines, 1) if '"type":"reading"' in line]
    edited = tmp_path / "edited.jsonl"
    for line in readings[::len(readings) // 20][:20]:  # the red team's 20 trials
        _edited_copy(recorded, edited, line, ("crc", "seq") if line % 2 else ("crc",))
        code, _, err = here(capsys, "refit", edited)
        assert code == 4 and f"edited.jsonl:{line}: " in one_line(err), err
    for args in (["diagnose", edited], ["report", edited, "--out", tmp_path / "r"],
                 ["offsets", "show", edited], ["history", "add", edited],
                 ["session", "export", edited, tmp_path / "e.csv"]):
        code, _, err = here(capsys, *args)
        assert code == 4 and "the session was edited after it was written" in one_line(err)
        assert "--accept-edited" in err
    assert not (tmp_path / "r").exists() and not (tmp_path / "e.csv").exists()

    code, out, _ = here(capsys, "refit", edited, "--json", "--accept-edited")
    assert code == 0 and json.loads(out)["edited"][0]["line"] == line
    code, out, _ = here(capsys, "refit", edited, "--accept-edited")
    assert code == 0 and f"edited: line {line} " in " ".join(out.split())
    code, _, err = here(capsys, "report", edited, "--out", tmp_path / "r", "--accept-edited",
                        "--history", "none")
    record = json.loads((tmp_path / "r" / "record.json").read_text(encoding="utf-8"))
    assert code == 0 and record["session"]["edited"][0]["line"] == line
    assert f"line {line}" in (tmp_path / "r" / "report.html").read_text(encoding="utf-8")


def test_a_session_cut_at_a_line_boundary_is_partial_everywhere(recorded, capsys, tmp_path):
    lines = recorded.read_text().splitlines(keepends=True)
    cut = tmp_path / "cut.jsonl"
    cut.write_text("".join(lines[:len(lines) // 2]))  # a killed run: no end record
    shutil.copy(recorded.parent / "history.sqlite", tmp_path / "h.sqlite")
    before = (tmp_path / "h.sqlite").read_bytes()
    for args in (["refit", cut], ["diagnose", cut], ["report", cut],
                 ["session", "export", cut, tmp_path / "c.csv"], ["offsets", "show", cut]):
        code, _, err = here(capsys, *args)
        assert code == 4 and "partial: " in one_line(err) and "of 72 planned readings" in err
        assert "--partial" in err
    n = int(one_line(err).split("partial: ")[1].split()[0])
    says = f"partial: {n} of 72 planned readings (no end record"
    code, out, err = here(capsys, "refit", cut, "--partial")
    assert code == 0 and says in " ".join(out.split())
    code, out, _ = here(capsys, "refit", cut, "--partial", "--json")
    assert code == 0 and json.loads(out)["partial"]["says"].startswith(says)
    code, out, err = here(capsys, "diagnose", cut, "--partial", "--history", tmp_path / "h.sqlite")
    assert code == 0 and says in " ".join(out.split())
    assert "history: nothing recorded: partial" in err
    code, out, err = here(capsys, "session", "export", cut, tmp_path / "c.csv", "--partial")
    assert code == 0 and says in " ".join(out.split())
    code, _, err = here(capsys, "report", cut, "--partial", "--out", tmp_path / "r")
    assert code == 0 and says in err
    record = json.loads((tmp_path / "r" / "record.json").read_text(encoding="utf-8"))
    assert record["campaign"]["partial"].startswith(says)
    assert says in " ".join((tmp_path / "r" / "report.html").read_text(encoding="utf-8")
                            .split())
    code, _, err = here(capsys, "history", "add", cut, "--history", tmp_path / "h.sqlite")
    assert code == 4 and "enters the history when its campaign completes" in one_line(err)
    assert (tmp_path / "h.sqlite").read_bytes() == before  # nothing partial entered


@pytest.mark.parametrize("url", ["postgresql://u:pw@host:notaport/db",
                                 "postgresql://u:pw@[::1/db",
                                 "postgresql://u:pw@localhost/db?sslmode=bogus"])
def test_a_malformed_history_url_is_one_line(recorded, capsys, caplog, tmp_path, url):
    for args, code_wanted in ((["history", "X", "--history", url], 2),
                              (["history", "add", recorded, "--history", url], 2),
                              (["offsets", "restore", "--machine", "X", "--to", "Y",
                                "--history", url], 2),
                              (["diagnose", recorded, "--json", "--history", url], 0),
                              (["report", recorded, "--out", tmp_path / "r", "--history", url],
                               0)):
        caplog.clear()
        code, _, err = here(capsys, *args)
        assert code == code_wanted, (args, err)
        # an error on stderr; a warning where the history is optional (logged, or said)
        said = err + "".join(f"{r.getMessage()}\n" for r in caplog.records)
        line = one_line(said)
        assert "--history" in line and "pw" not in said and "***" in line, line


@pytest.mark.parametrize(("kind", "text", "words"), [
    ("campaign", "[protocol]\nsettle_s = " + "9" * 40 + "\n", "protocol.settle_s"),
    ("campaign", "[protocol]\ncycles = " + "9" * 40 + "\n", "at most 19 digits"),
    ("effects", "[squareness]\nxy = 1e30\n", "squareness.xy must be -20..20"),
    ("effects", "[joint_offset]\nx = " + "9" * 40 + "\n", "at most 19 digits"),
    ("effects", "[gauges]\nnoise_mm = " + "9" * 5000 + "\n", "not valid TOML"),
])
def test_fuzzed_numbers_in_files_are_bad_input(tmp_path, capsys, kind, text, words):
    path = write_campaign(tmp_path, seed=1)
    if kind == "campaign":
        path.write_text(path.read_text().replace("[protocol]\nsettle_s = 0.5\n", "") + text)
        args = ["run", path]
    else:
        (tmp_path / "effects.toml").write_text(text)
        args = ["sim", "--effects", tmp_path / "effects.toml"]
    code, _, err = here(capsys, *args)
    assert code == 2 and words in one_line(err) and ":" in err, err


def test_fuzzed_numbers_in_a_readings_csv_are_bad_input(recorded, capsys, tmp_path):
    assert here(capsys, "session", "export", recorded, tmp_path / "r.csv")[0] == 0
    lines = (tmp_path / "r.csv").read_text().splitlines()
    for column, value in ((1, "9" * 40), (10, "１２"), (4, "1e308"), (10, "1_000")):
        cells = lines[5].split(",")
        cells[column] = value
        bad = tmp_path / "bad.csv"
        bad.write_text("\n".join([*lines[:5], ",".join(cells), *lines[6:]]) + "\n")
        code, _, err = here(capsys, "refit", bad, "-m", recorded.parent / "machine.toml")
        assert code == 2 and "bad.csv:6: " in one_line(err), err


def test_a_history_failing_its_integrity_check_is_not_written_to(recorded, capsys, tmp_path):
    history = tmp_path / "h.sqlite"
    shutil.copy(recorded.parent / "history.sqlite", history)
    with sqlite3.connect(history) as conn:
        page = conn.execute("PRAGMA page_size").fetchone()[0]
        root = conn.execute("SELECT rootpage FROM sqlite_master WHERE name = "
                            "'ogacq_events'").fetchone()[0]
    raw = bytearray(history.read_bytes())
    start = (root - 1) * page
    raw[start + 8:start + 12] = b"\xff\xff\xff\xff"  # the first cell pointers of its root page
    history.write_bytes(bytes(raw))
    code, _, err = here(capsys, "history", "add", recorded, "--history", history)
    line = one_line(err)
    assert code == 3 and "nothing is recorded into it" in line and ".recover" in line
    assert history.read_bytes() == bytes(raw)


# ---------------------------------------------------------------- a full or read-only disk
# The disk "fills up" through RLIMIT_FSIZE (tests.cli.helpers.with_file_size_limit: a
# write past the limit fails with EFBIG as one on a full disk with ENOSPC, root or not);
# a folder is read-only through a read-only bind mount in a namespace of the command's
# own (EROFS), else its write permission taken away (helpers.on_read_only).

CONTROLLER_CAMPAIGN = """machine = "machine.toml"
session = "session.jsonl"
[controller]
profile = "cia402"
port = "127.0.0.1:1"
""" + "".join(f'[[gauges]]\ngauge = "{k}"\nprotocol = "mitutoyo-01a"\nport = "/dev/ttyUSB{n}"\n'
              for n, k in enumerate(("y_x", "z_x", "x_y", "z_y", "x_z", "y_z")))


def _leftovers(folder: Path, keep: set[str]) -> list[str]:
    return sorted(p.name for p in folder.iterdir() if p.name not in keep)


def test_offsets_write_on_a_read_only_session_folder_is_one_line_and_writes_nothing(
        recorded, tmp_path):
    folder = tmp_path / "ro"
    folder.mkdir()
    shutil.copy(recorded, folder / "session.jsonl")
    shutil.copy(recorded.parent / "machine.toml", folder / "machine.toml")
    (folder / "campaign.toml").write_text(CONTROLLER_CAMPAIGN)
    before = (folder / "session.jsonl").read_bytes()
    ran = on_read_only(folder, "offsets", "write", folder / "session.jsonl", "-c",
                       folder / "campaign.toml", "--yes", "--history", "none")
    if ran is None:
        pytest.skip("no way to make a folder read-only here (root without mount namespaces)")
    line = one_line(ran.stderr)
    assert ran.returncode == 3 and "nothing was written to the controller" in line, line
    assert (folder / "session.jsonl").read_bytes() == before
    assert _leftovers(folder, {"session.jsonl", "machine.toml", "campaign.toml"}) == []


def test_salvage_on_a_full_disk_leaves_nothing_and_a_retry_works(recorded, tmp_path):
    first_reading = next(k for k, line in enumerate(recorded.read_text().splitlines(), 1)
                         if '"type":"reading"' in line)
    damaged = _edited_copy(recorded, tmp_path / "damaged.jsonl", first_reading)
    out = tmp_path / "out" / "saved.jsonl"
    out.parent.mkdir()
    ran = with_file_size_limit(10_000, "session", "salvage", damaged, out)
    assert ran.returncode == 3 and "saved.jsonl" in one_line(ran.stderr), ran.stderr
    assert list(out.parent.iterdir()) == []  # no 0-byte file in the way, no temporary
    retried = run_ogacq("session", "salvage", damaged, out)
    assert retried.returncode == 0 and "left out" in retried.stdout, retried.stderr
    assert run_ogacq("session", "check", out).returncode == 0


def test_report_and_history_add_on_a_full_disk_are_one_line_and_a_retry_works(recorded,
                                                                               tmp_path):
    shutil.copy(recorded, tmp_path / "s.jsonl")
    report = tmp_path / "report"
    ran = with_file_size_limit(20_000, "report", tmp_path / "s.jsonl", "--out", report,
                               "--history", "none")
    assert ran.returncode == 3 and "cannot write" in one_line(ran.stderr), ran.stderr
    assert not report.exists()  # the figures written before the disk filled: removed
    shutil.copy(recorded.parent / "machine.toml", tmp_path / "export.csv")  # a file to replace
    ran = with_file_size_limit(2_000, "session", "export", tmp_path / "s.jsonl",
                               tmp_path / "export.csv", "--force")
    assert ran.returncode == 3 and "export.csv" in one_line(ran.stderr), ran.stderr
    assert (tmp_path / "export.csv").read_bytes() == (recorded.parent / "machine.toml"
                                                      ).read_bytes()  # as it was
    assert run_ogacq("report", tmp_path / "s.jsonl", "--out", report, "--history",
                     "none").returncode == 0
    history = tmp_path / "h.sqlite"
    ran = with_file_size_limit(8_000, "history", "add", tmp_path / "s.jsonl", "--history",
                               history)
    assert ran.returncode == 3 and str(history) in one_line(ran.stderr), ran.stderr
    added = run_ogacq("history", "add", tmp_path / "s.jsonl", "--history", history)
    assert added.returncode == 0 and "calibration:" in added.stdout, added.stderr


def test_history_add_into_a_read_only_folder_is_one_line(recorded, tmp_path):
    folder = tmp_path / "ro"
    folder.mkdir()
    shutil.copy(recorded, tmp_path / "s.jsonl")
    ran = on_read_only(folder, "history", "add", tmp_path / "s.jsonl", "--history",
                       folder / "h.sqlite")
    if ran is None:
        pytest.skip("no way to make a folder read-only here (root without mount namespaces)")
    assert ran.returncode == 3 and "h.sqlite" in one_line(ran.stderr), ran.stderr
    assert list(folder.iterdir()) == []
