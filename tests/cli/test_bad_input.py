"""Every command, fed its bad inputs, answers with one line on stderr and the documented
exit code (README, "Exit codes"), before it starts any work: no traceback, no
half-made output.

The table lists the commands the app has: a new command without its bad inputs
here fails ``test_every_command_has_bad_inputs``.
"""

from __future__ import annotations

import shutil
from dataclasses import replace
from pathlib import Path

import pytest

from ogacq.cli.app import EXIT_CODES, OgacqCommands, main
from ogacq.cli.lazy import LazyGroupSpec
from ogacq.io.tables import write_readings
from ogacq.model.machine import PAPER_PROTOTYPE
from ogacq.session.convert import import_readings
from ogacq.session.store import SessionWriter
from tests.uncertainty.campaigns import papers_campaign

PAPER = Path(__file__).resolve().parents[2] / "ogacq" / "examples" / "paper"
MISSING = "missing.toml"  # in the test's folder, never created

# command -> [(arguments, exit code, words the line must hold)]; names below are files
# of the test's folder (see `folder`), "/proc" refuses new files even to root.
BAD_INPUTS: dict[str, list[tuple[list[str], int, str]]] = {
    "run": [([MISSING], 2, MISSING),
            (["machine.toml"], 2, "machine.toml"),
            (["machine.toml", "--override-expired", " "], 2, "--override-expired")],
    "resume": [(["missing.jsonl"], 2, "missing.jsonl"),
               (["deviations.csv"], 2, "deviations.csv"),
               (["deviations.csv"], 2, "not an ogacq session (line 1 is not a JSON record)")],
    "demo": [(["--seed", "-5", "--out", "demo"], 2, "--seed"),
             (["--profile", "nope", "--out", "demo"], 2, "'nope'"),
             (["--speed", "0", "--out", "demo"], 2, "--speed"),
             (["--effects", MISSING, "--out", "demo"], 2, MISSING),
             # checked before the folder is made: it named the copy, left the folder
             (["--effects", "broken.toml", "--out", "demo"], 2, "broken.toml:1: not valid TOML"),
             (["--out", "machine.toml"], 2, "not a folder"),
             (["--out", "/proc/nope"], 2, "/proc/nope"),
             (["--date", "10/01/2026", "--out", "demo"], 2, "--date"),
             (["--date", "2026-02-30", "--out", "demo"], 2,
              "--date = '2026-02-30' is not a date and time: day is out of range for month"),
             (["--date", "2026-01-10T09:00+01:00", "--out", "demo"], 2,
              "carries a UTC offset"),
             (["--ambient-c", "120", "--out", "demo"], 2, "--ambient-c"),
             (["--override-expired", "", "--out", "demo"], 2, "--override-expired")],
    "calibrate": [([], 2, "--simulator"),
                  (["machine.toml", "--simulator"], 2, "not both"),
                  (["--simulator", "--seed", "-5"], 2, "--seed"),
                  (["--simulator", "--speed", "0"], 2, "--speed"),
                  (["--simulator", "--profile", "nope"], 2, "'nope'"),
                  (["--simulator", "--out", "machine.toml", "--yes"], 2, "not a folder"),
                  (["--simulator", "--out", "/proc/nope", "--yes"], 2, "/proc/nope"),
                  (["--simulator", "--effects", MISSING, "--out", "cal", "--yes"], 2, MISSING),
                  (["machine.toml", "--out", "cal", "--yes"], 2, "machine.toml"),
                  (["--resume", "nowhere"], 2, "no calibration procedure"),
                  (["--resume", "nowhere", "--simulator"], 2, "alone"),
                  (["--simulator", "--out", "cal", "--override-expired", " "], 2,
                   "--override-expired"),
                  (["--simulator", "--out", "cal"], 4, "--yes"),
                  (["--simulator", "--axis-scales", "x,w", "--out", "cal", "--yes"], 2,
                   "--axis-scales: names axes x, y or z, got w"),
                  (["machine.toml", "--axis-scales", "x", "--out", "cal", "--yes"], 2,
                   "--axis-scales: is the simulator's"),
                  (["--simulator", "--scale-runs", "1", "--out", "cal", "--yes"], 2,
                   "--scale-runs")],
    "positioning": [([MISSING], 2, MISSING),
                    (["machine.toml"], 2, "machine.toml"),
                    ([MISSING, "--axis", "w"], 2, "--axis"),
                    ([MISSING, "--runs", "1"], 2, "--runs")],
    "diagnose": [(["missing.csv", "-m", "machine.toml"], 2, "missing.csv"),
                 # a session without its end record: analysed only with --partial (4)
                 (["session.jsonl"], 4, "partial: 0 readings"),
                 (["machine.toml", "-m", "machine.toml"], 2, "machine.toml"),
                 (["deviations.csv", "-m", "broken.toml"], 2, "broken.toml")],
    "refit": [(["missing.csv", "-m", "machine.toml"], 2, "missing.csv"),
              (["session.jsonl"], 4, "analyse what it holds with --partial"),
              (["deviations.csv", "-m", "machine.toml", "--params", "nope"], 2, "--params"),
              (["deviations.csv", "-m", "broken.toml"], 2, "broken.toml")],
    "plan": [(["-m", MISSING], 2, MISSING),
             (["-m", "machine.toml", "--seed", "-5"], 2, "--seed"),
             (["-m", "machine.toml", "--postures", "zero,banana"], 2, "'banana'"),
             (["-m", "machine.toml", "--noise", "-1"], 2, "--noise"),
             (["-m", "machine.toml", "--assume", "joint_offset.q=1"], 2, "--assume")],
    "report": [(["missing.jsonl"], 2, "missing.jsonl"),
               (["deviations.csv"], 2, "not an ogacq session"),
               (["session.jsonl", "--out", "/proc/nope"], 2, "/proc/nope"),
               (["session.jsonl", "--out", "machine.toml"], 2, "not a folder"),
               (["session.jsonl", "--diagnosis", "machine.toml"], 2, "not JSON"),
               (["session.jsonl"], 4, "--partial")],
    "sim": [(["--seed", "-5"], 2, "--seed"),
            (["--profile", "nope"], 2, "'nope'"),
            (["--gauge", "z_q=usb-itn"], 2, "z_q"),
            (["--machine", MISSING], 2, MISSING),
            (["--effects", MISSING], 2, MISSING),
            (["--port", "70000"], 2, "--port"),
            (["--profile", "iai-pcon", "--port", "1502"], 2, "--port"),
            (["--write-campaign", "machine.toml"], 2, "--force"),
            # the machine file beside it exists (`ogacq init machine`): why, and the way out
            (["--write-campaign", "c.toml"], 2, "give --machine machine.toml to simulate"),
            (["--write-campaign", "/nonexistent/dir/c.toml"], 2, "/nonexistent/dir")],
    "init": [(["banana"], 2, "'banana'"),
             (["machine", "machine.toml"], 2, "--force"),
             (["campaign", "/nonexistent/dir/c.toml"], 2, "/nonexistent/dir"),
             (["machine", "/proc/m.toml"], 2, "/proc/m.toml")],
    "wizard": [(["--seed", "-5"], 2, "--seed"),
               (["--profile", "nope"], 2, "'nope'"),
               (["--gauge-protocol", "nope"], 2, "'nope'"),
               (["--indicators", "4"], 2, "--indicators"),
               (["--simulate-fault", "x_y:silent@3"], 2, "--simulate-fault"),
               (["--simulator", "--out", "/proc/nope"], 2, "/proc/nope")],
    "offsets show": [(["missing.jsonl"], 2, "missing.jsonl"),
                     (["deviations.csv"], 2, "not an ogacq session (line 1 is not a JSON"),
                     (["session.jsonl", "--max-change-mm", "-1"], 2, "--max-change-mm")],
    "offsets write": [(["missing.jsonl"], 2, "missing.jsonl"),
                      (["deviations.csv"], 2, "deviations.csv")],
    "offsets restore": [(["missing.jsonl"], 2, "missing.jsonl"),
                        (["session.jsonl"], 2, "no write-back is recorded"),
                        (["--machine", "OG-1"], 2, "--to: is missing"),
                        (["session.jsonl", "--machine", "OG-1", "--to", "S-1"], 2, "not both"),
                        (["--machine", "OG-1", "--to", "S-1"], 2, "no history yet")],
    "maps show": [(["missing.jsonl"], 2, "missing.jsonl"),
                  (["session.jsonl"], 2, "no maps write")],
    "maps restore": [(["missing.jsonl"], 2, "missing.jsonl"),
                     (["session.jsonl"], 2, "nothing to restore")],
    "history show": [(["OG-1"], 2, "no history yet"),
                     ([], 2, "no history yet"),
                     (["OG-1", "--history", "nope.sqlite"], 3, "no history here"),
                     (["OG-1", "--history", "machine.toml"], 3, "file is not a database"),
                     (["OG-1", "--history", "mysql://u@h/db"], 2, "'mysql' is not supported"),
                     (["OG-1", "--history", "h.sqlite", "--plot", "p.txt"], 2, "PNG"),
                     (["OG-1", "--history", "h.sqlite", "--plot", "machine.png"], 2,
                      "without --force")],
    "history add": [(["missing.jsonl"], 2, "missing.jsonl"),
                    (["deviations.csv"], 2, "not an ogacq session"),
                    (["session.jsonl", "--history", "none"], 2, "no history to add to"),
                    (["session.jsonl", "--history", "h.sqlite"], 4, "campaign completes"),
                    # recorded before a blank machine name was refused: no machine to file under
                    (["nameless.jsonl", "--history", "h.sqlite"], 2,
                     "names no machine: the history files calibrations by machine")],
    "session show": [(["missing.jsonl"], 2, "missing.jsonl"),
                     (["deviations.csv"], 2, "deviations.csv")],
    "session export": [(["session.jsonl", "/nonexistent/dir/o.csv"], 2, "/nonexistent/dir"),
                       (["session.jsonl", "machine.toml"], 2, "not overwriting"),
                       (["session.jsonl", ".", "--force"], 2, "is a folder"),
                       (["missing.jsonl", "out.csv"], 2, "missing.jsonl"),
                       (["session.jsonl", "out.csv"], 4, "--partial")],
    "session import": [(["missing.csv", "new.jsonl", "-m", "machine.toml"], 2, "missing.csv"),
                       (["deviations.csv", "/proc/nope/s.jsonl", "-m", "machine.toml"], 2,
                        "/proc/nope"),
                       (["deviations.csv", "new.jsonl"], 2, "--machine"),
                       (["deviations.csv", "/nonexistent/s.jsonl", "-m", "machine.toml"], 2,
                        "/nonexistent")],
    "session check": [(["missing.jsonl"], 2, "missing.jsonl")],
    "session salvage": [(["session.jsonl", "/nonexistent/dir/s.jsonl"], 2, "/nonexistent/dir"),
                        (["missing.jsonl", "new.jsonl"], 2, "missing.jsonl")],
}


def command_names() -> set[str]:
    names = set()
    for name, target in OgacqCommands.table.items():
        if isinstance(target, LazyGroupSpec):
            names |= {f"{name} {sub}" for sub in target.commands}
        else:
            names.add(name)
    return names


@pytest.fixture(scope="module")
def folder(tmp_path_factory) -> Path:
    """A machine file, a broken TOML, a deviations CSV and a session with nothing but
    its header (it names no campaign file and no write-back)."""
    folder = tmp_path_factory.mktemp("bad-input")
    shutil.copy(PAPER / "machine.toml", folder / "machine.toml")
    shutil.copy(PAPER / "experiment2_12.csv", folder / "deviations.csv")
    (folder / "broken.toml").write_text("leg_length_mm = [\n")
    (folder / "machine.png").write_bytes(b"\x89PNG\r\n\x1a\n")  # a plot not to overwrite
    SessionWriter.create(folder / "session.jsonl", {"machine": {}, "plan": None}).close()
    obs, _ = papers_campaign()
    write_readings(folder / "readings.csv", obs.layout, obs.values)
    nameless = replace(PAPER_PROTOTYPE, name="")
    import_readings(folder / "readings.csv", nameless, folder / "nameless.jsonl")
    return folder


def test_every_command_has_bad_inputs():
    assert set(BAD_INPUTS) == command_names()


@pytest.mark.parametrize(("command", "args", "code", "words"), [
    (command, args, code, words)
    for command, cases in BAD_INPUTS.items() for args, code, words in cases])
def test_bad_input_is_one_line_and_its_exit_code(command, args, code, words, folder, capsys,
                                                monkeypatch):
    monkeypatch.chdir(folder)
    before = sorted(p.name for p in folder.iterdir())
    assert main([*command.split(), *args]) == code
    err = capsys.readouterr().err
    assert len(err.splitlines()) == 1, err
    assert err.startswith("ogacq: ") and "Traceback" not in err, err
    assert words in err, err
    assert sorted(p.name for p in folder.iterdir()) == before  # nothing made


def test_the_help_lists_the_exit_codes(capsys):
    assert main(["--help"]) == 0
    help_text = " ".join(capsys.readouterr().out.split())
    assert " ".join(EXIT_CODES.split()) in help_text
    readme = (Path(__file__).resolve().parents[2] / "README.md").read_text()
    for code in ("0", "1", "2", "3", "4", "130"):
        assert f"| {code} |" in readme
