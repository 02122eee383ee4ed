"""The README's exit-code table is what the commands return (issue 38.8): the table is
read from README.md and every code it names is checked by a case a technician meets,
in a real process (the 141 of a reader who left needs one)."""

from __future__ import annotations

import re
import signal
import subprocess
import sys
import time
from pathlib import Path

from ogacq.model.gauges import GAUGE_KEYS
from tests.campaign.conftest import CONTROLLER, HEAD, MACHINE, gauge, write_campaign
from tests.campaign.test_resume import readings_on_disk, start
from tests.writeback.conftest import ogacq, sim_campaign, simulator, synthetic_session

README = Path(__file__).resolve().parents[2] / "README.md"
OFFSETS = {"x": 0.8, "y": -0.6, "z": 1.2}


def readme_exit_codes() -> dict[int, str]:
    """code -> meaning, from the table under README's "## Exit codes"."""
    section = README.read_text(encoding="utf-8").split("## Exit codes", 1)[1].split("\n## ")[0]
    return {int(m[1]): m[2] for m in re.finditer(r"^\| (\d+) \| (.+) \|$", section, re.M)}


def test_every_exit_code_the_readme_names_is_returned_as_it_says(tmp_path):
    got: dict[int, list[str]] = {}

    def case(code: int, ran: subprocess.CompletedProcess | subprocess.Popen, what: str,
             ) -> None:
        assert ran.returncode == code, (what, ran.returncode)
        got.setdefault(code, []).append(what)

    case(0, ogacq("init", "machine", tmp_path / "m.toml"), "a template written")
    case(2, ogacq("refit", tmp_path / "none.csv", "--machine", tmp_path / "m.toml"),
         "a file that does not exist")

    # 3: a controller nobody answers on
    station = tmp_path / "dead"
    station.mkdir()
    (station / "machine.toml").write_text(MACHINE)
    dead = station / "campaign.toml"
    dead.write_text(HEAD + CONTROLLER + "".join(gauge(key, f"/dev/null-{key}")
                                                for key in GAUGE_KEYS))
    session = synthetic_session(station / "s.jsonl", dead, offsets_mm=OFFSETS)
    case(3, ogacq("offsets", "write", session, "--yes"), "the controller cannot be reached")

    # 1 and 4: at the write-back, declined at its prompt, and refused as unreliable
    with simulator(tmp_path / "sim", "cia402", seed=4) as info:
        live = sim_campaign(tmp_path / "sim", info, name="campaign")
        good = synthetic_session(tmp_path / "good.jsonl", live, offsets_mm=OFFSETS)
        case(1, ogacq("offsets", "write", good, stdin="n\n"), "declined at the prompt")
        askew = synthetic_session(tmp_path / "askew.jsonl", live, offsets_mm=OFFSETS,
                                  effects={"squareness.xy": 1.0})
        case(4, ogacq("offsets", "write", askew, "--yes"), "refused: not within the noise")

    # 130: Ctrl-C in a campaign; then a second run on its unfinished session is bad
    # input (2) naming the command that continues it
    campaign = write_campaign(tmp_path / "c", seed=9, speed=1)
    session = campaign.parent / "session.jsonl"
    proc = start("run", campaign)
    end = time.monotonic() + 60
    while readings_on_disk(session) < 1:
        assert proc.poll() is None and time.monotonic() < end
        time.sleep(0.05)
    proc.send_signal(signal.SIGINT)
    proc.communicate(timeout=60)
    case(130, proc, "interrupted")
    again = ogacq("run", campaign)
    case(2, again, "a second run on an unfinished session")
    assert f"ogacq resume {session}" in again.stderr

    # 141: the reader of the output left (`ogacq --help | head`), gone before a word
    reader_left = subprocess.Popen([sys.executable, "-m", "ogacq", "--help"],
                                   stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    assert reader_left.stdout is not None
    reader_left.stdout.close()
    reader_left.wait(60)
    assert reader_left.stderr is not None and reader_left.stderr.read() == b""
    case(141, reader_left, "the reader left: nothing said")

    assert sorted(got) == sorted(readme_exit_codes())
