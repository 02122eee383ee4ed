"""One rendering layer for terminal text (issues 38.6 and 35.7): rich wraps every line
at the terminal's width between words, stderr's errors included, and no module
leans on a private (``_``-prefixed) name of typer, click or rich.

At 80 columns no line the commands write is wider than the terminal: a wider one is
cut by the terminal wherever the 80th column falls, mid-word ("cam-paign"), which is
what a technician saw at the end of a run and in the errors."""

from __future__ import annotations

import ast
import fcntl
import os
import struct
import subprocess
import sys
import termios
from pathlib import Path

import pytest

from tests.campaign.conftest import write_campaign

ROOT = Path(__file__).resolve().parents[2]
PAPER = ROOT / "ogacq" / "examples" / "paper"
WIDTH = 80
PRIVATE_OF = ("typer", "click", "rich")


def private_names(path: Path) -> list[str]:
    """The ``_``-prefixed modules or names of typer, click or rich ``path`` imports."""
    found = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.ImportFrom) and node.module:
            parts = node.module.split(".")
            if parts[0] in PRIVATE_OF and (
                    any(p.startswith("_") for p in parts)
                    or any(a.name.startswith("_") for a in node.names)):
                found.append(f"{path.relative_to(ROOT)}:{node.lineno} from {node.module}")
        elif isinstance(node, ast.Import):
            found += [f"{path.relative_to(ROOT)}:{node.lineno} import {a.name}"
                      for a in node.names if a.name.split(".")[0] in PRIVATE_OF
                      and any(p.startswith("_") for p in a.name.split("."))]
    return found


def test_no_private_name_of_typer_click_or_rich_is_imported():
    sources = [*(ROOT / "ogacq").rglob("*.py"), *(ROOT / "drivers").rglob("*.py")]
    assert [hit for path in sources for hit in private_names(path)] == []


def on_terminal(*args: object, columns: int = WIDTH, term: str = "dumb") -> tuple[int, str]:
    """``ogacq ARGS`` with stdout and stderr on a pseudo-terminal ``columns`` wide: its
    exit code and what the terminal received."""
    controller, terminal = os.openpty()
    fcntl.ioctl(terminal, termios.TIOCSWINSZ, struct.pack("HHHH", 24, columns, 0, 0))
    env = {k: v for k, v in os.environ.items() if k not in ("COLUMNS", "LINES")}
    proc = subprocess.Popen([sys.executable, "-m", "ogacq", *map(str, args)],
                            stdin=subprocess.DEVNULL, stdout=terminal, stderr=terminal,
                            env={**env, "TERM": term})
    os.close(terminal)
    received = b""
    while True:
        try:
            chunk = os.read(controller, 65536)
        except OSError:  # EIO: the process closed the terminal's last descriptor
            break
        if not chunk:
            break
        received += chunk
    os.close(controller)
    return proc.wait(60), received.decode("utf-8", "replace").replace("\r\n", "\n")


def too_wide(text: str, columns: int = WIDTH) -> list[str]:
    return [line for line in text.splitlines() if len(line) > columns]


@pytest.mark.parametrize("args", [
    ["refit", PAPER / "experiment2_12.csv", "--machine", PAPER / "machine.toml"],
    ["diagnose", PAPER / "experiment2_12.csv", "--machine", PAPER / "machine.toml"],
    ["session", "--help"],
])
def test_a_command_fits_the_terminal(args):
    code, text = on_terminal(*args)
    assert code == 0, text
    assert too_wide(text) == [], text
    # a summary cut short: `session --help` cut its commands' at 45 characters
    assert [line for line in text.splitlines()[1:] if line.endswith("...")] == []


def test_an_error_wraps_between_words_on_a_terminal_and_is_one_line_to_a_pipe(tmp_path):
    missing = tmp_path / "a-folder-with-a-rather-long-name-as-shop-floor-paths-have"
    code, text = on_terminal("refit", missing / "readings.csv", "--machine",
                             PAPER / "machine.toml")
    assert code == 2 and too_wide(text) == [] and len(text.splitlines()) > 1, text
    assert " ".join(text.split()).startswith("ogacq: error: ")
    piped = subprocess.run([sys.executable, "-m", "ogacq", "refit", missing / "readings.csv",
                            "--machine", PAPER / "machine.toml"], capture_output=True,
                           text=True, timeout=60)
    assert piped.returncode == 2 and piped.stderr.count("\n") == 1  # a log's one line


def test_the_end_of_a_run_fits_80_columns(tmp_path):
    """The verdict, the record and the next commands, as the issue found them cut."""
    campaign = write_campaign(tmp_path / "c", seed=3, line_at_speed=True,
                              extra="cycles = 1\n[stability]\nreadings = 2\n")
    ran = subprocess.run([sys.executable, "-m", "ogacq", "run", campaign, "--history",
                          "none"], capture_output=True, text=True, timeout=300,
                         env={**os.environ, "COLUMNS": str(WIDTH)})
    assert ran.returncode == 0, ran.stderr
    end = ran.stdout[ran.stdout.index("verdict:"):]
    assert too_wide(end) == [], end
    assert "next: ogacq" in end


def test_a_rehearsal_has_one_seed_and_one_pace_and_the_readme_says_them():
    """--speed was 1 (sim), 20 (wizard) and 25 (demo, calibrate)."""
    import inspect

    from ogacq.cli.calibrate_cmd import calibrate
    from ogacq.cli.demo_cmd import demo
    from ogacq.cli.options import DEFAULT_SEED, DEFAULT_SPEED
    from ogacq.cli.sim_cmd import sim
    from ogacq.cli.wizard_cmd import wizard

    for command in (demo, calibrate, sim, wizard):
        defaults = {n: p.default for n, p in inspect.signature(command).parameters.items()}
        assert (defaults["seed"], defaults["speed"]) == (DEFAULT_SEED, DEFAULT_SPEED), command
    table = (ROOT / "README.md").read_text(encoding="utf-8").split("## Defaults", 1)[1]
    assert f"| `--speed` | {DEFAULT_SPEED:g} " in table and \
        f"| `--seed` | {DEFAULT_SEED} " in table


def test_every_value_with_its_std_is_at_the_std_s_decimal_place(capsys):
    """One rounding rule on the console as on the page (the demo's effect read
    "+382.6237 ± 23.8388 ppm" on the console, "+383 ± 24 ppm" on the page): the value
    at its std's decimal place, the std to two significant digits."""
    import re

    from ogacq.cli.app import main

    assert main(["diagnose", str(PAPER / "experiment2_12.csv"), "--machine",
                 str(PAPER / "machine.toml")]) == 0
    pairs = re.findall(r"([+-]\d+(?:\.(\d+))?) ± (\d+(?:\.(\d+))?)",
                       " ".join(capsys.readouterr().out.split()))
    assert pairs
    for value, value_decimals, std, std_decimals in pairs:
        assert len(value_decimals) == len(std_decimals), (value, std)
        assert len(std.replace(".", "").lstrip("0")) == 2, std


def test_report_says_what_it_is_doing_on_a_terminal_only(tmp_path):
    """`ogacq report` was silent for 15-18 s: on a terminal a spinner names the step;
    to a pipe one line on stderr says the work, and the output's first line is the
    page's path, as before (then the next command)."""
    session = ROOT / "tests" / "golden" / "session.jsonl"
    code, text = on_terminal("report", session, "--out", tmp_path / "t", "--history", "none",
                             term="xterm")
    assert code == 0, text
    assert "issuing the record" in text and "diagnosing session.jsonl" in text
    piped = subprocess.run([sys.executable, "-m", "ogacq", "report", session, "--out",
                            tmp_path / "p", "--history", "none"], capture_output=True,
                           text=True, timeout=300)
    assert piped.returncode == 0, piped.stderr
    assert len(piped.stderr.splitlines()) == 1 and "issuing the record" in piped.stderr
    assert piped.stdout.splitlines()[0] == str(tmp_path / "p" / "report.html")
    assert "\nnext: " in piped.stdout  # the end: wrapped at 80 columns to a pipe


def test_the_search_table_wraps_between_effect_names(capsys, monkeypatch):
    """At 80 columns the library search's "added" column was folded inside a name
    ("encoder_scale." over "y"): each name is whole on its line now, every line within
    the width."""
    from ogacq.cli.render_diagnosis import print_diagnosis
    from ogacq.diagnose.diagnosis import diagnose
    from tests.diagnose.campaigns import simulate

    monkeypatch.setenv("COLUMNS", str(WIDTH))
    found = diagnose(simulate({"encoder_scale.x": 3000.0, "encoder_scale.z": 2000.0}, 1))
    assert [s.label for s in found.selection.steps] == ["encoder_scale.x + encoder_scale.z"]
    print_diagnosis(found)
    out = capsys.readouterr().out
    table = out[out.index("Search"):out.index("residual rms per gauge")]
    assert too_wide(out) == [] and "encoder_scale.x +" in table, table
    assert "│ encoder_scale.z " in table, table


def test_session_check_and_init_fit_80_columns(tmp_path, capsys, monkeypatch):
    """`session check`'s one line (its last) was 100-130 characters with a session's
    path, and `init`'s too: wrapped between words now, to a pipe as on a terminal."""
    from ogacq.cli.app import main

    monkeypatch.setenv("COLUMNS", str(WIDTH))
    golden = ROOT / "tests" / "golden" / "session.jsonl"
    assert main(["session", "check", str(golden)]) == 0
    out = capsys.readouterr().out
    assert too_wide(out) == [] and "every one as written" in " ".join(out.split()), out
    deep = tmp_path / "a-folder-with-a-rather-long-name-as-shop-floor-paths-have"
    deep.mkdir()
    assert main(["init", "campaign", str(deep / "campaign.toml")]) == 0
    out = capsys.readouterr().out
    assert too_wide(out) == [] and "then `ogacq run" in " ".join(out.split()), out


def test_the_map_search_table_names_each_term_whole(capsys, monkeypatch):
    """At 80 columns the map search's "added" column cut a term's name
    ("lead_screw_cycli…"): the name is whole, its headers fold instead, every line
    within the width."""
    from ogacq.cli.render_maps import print_coverage
    from ogacq.diagnose.diagnosis import diagnose
    from ogacq.sim.truth import LeadScrewError
    from tests.diagnose.test_maps import campaign

    monkeypatch.setenv("COLUMNS", str(WIDTH))
    obs, _ = campaign(5, lead_screw={0: LeadScrewError(0.005, 5.0, 30.0)})
    found = diagnose(obs)
    assert found.mapped is not None and found.mapped.search.steps
    print_coverage(found)
    out = capsys.readouterr().out
    assert too_wide(out) == [] and "lead_screw_cyclic.x" in out, out


def test_plans_separating_design_fits_80_columns(capsys, monkeypatch):
    """`plan --scan-minutes` printed the design's lines whole (up to 200 characters):
    wrapped between words now, the machine time still said."""
    from ogacq.cli.app import main

    monkeypatch.setenv("COLUMNS", str(WIDTH))
    machine = Path(__file__).parents[2] / "ogacq" / "examples" / "machine.toml"
    assert main(["plan", "--machine", str(machine), "--trials", "0",
                 "--scan-minutes", "40"]) == 0
    out = capsys.readouterr().out
    assert too_wide(out) == [], out
    assert "min of machine time" in " ".join(out.split())


def test_end_of_input_at_a_yes_no_question_is_a_no_on_a_line_of_its_own(capsys, monkeypatch):
    """Ctrl-D at `offsets write`'s, `maps restore`'s or calibrate's question: no, and the
    prompt's line ended, so the command's next word starts a line (maps restore's
    "nothing restored" followed the prompt on its line)."""
    import io

    from ogacq.cli.options import confirmed

    monkeypatch.setattr("sys.stdin", io.StringIO(""))
    assert confirmed("Restore these maps?") is False
    said = capsys.readouterr()
    assert said.out.startswith("Restore these maps? [y/N]") and said.err == "\n"


def test_a_stopped_campaign_s_reason_is_shown_not_obeyed(capsys):
    # a stop's reason may quote a device's reply: run, resume and positioning printed it
    # raw (calibrate through plain()); now all three say it through one helper
    import typer

    from ogacq.cli.campaign_cmds import said_if_stopped
    from ogacq.protocol.runner import CampaignStopped

    stop = CampaignStopped("gauge z_y replied \x1b[2J", "interrupted")
    with pytest.raises(typer.Exit) as ended, said_if_stopped("campaign", "continue it"):
        raise stop
    assert ended.value.exit_code == stop.exit_code
    assert capsys.readouterr().err == ("ogacq: campaign interrupted: gauge z_y replied "
                                       "\\x1b[2J\nogacq: continue it\n")
