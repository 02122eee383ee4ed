"""Every command that produces something ends with the next command, naming the file;
every refusal names the file it refers to (issue 38.5): a session's diagnosis ends
with the write-back its model allows, a write with the validation run, and the
refusal of a fit that leaves something out names the session to diagnose."""

from __future__ import annotations

from tests.cli.test_terminal_text import on_terminal, too_wide
from tests.writeback.conftest import ogacq, sim_campaign, simulator, synthetic_session

OFFSETS = {"x": 0.8, "y": -0.6, "z": 1.2}


def last_line(text: str) -> str:
    """The output's last paragraph, as one line (a terminal's width may wrap it)."""
    return " ".join(text[text.rindex("next: "):].split())


def test_diagnose_write_and_refusal_name_the_next_command_and_the_file(tmp_path):
    with simulator(tmp_path, "cia402", seed=5) as info:
        campaign = sim_campaign(tmp_path, info, name="campaign")
        good = synthetic_session(tmp_path / "good.jsonl", campaign, offsets_mm=OFFSETS)
        askew = synthetic_session(tmp_path / "askew.jsonl", campaign, offsets_mm=OFFSETS,
                                  effects={"squareness.xy": 0.5})

        diagnosed = ogacq("diagnose", good, "--history", "none")
        assert diagnosed.returncode == 0, diagnosed.stderr
        assert last_line(diagnosed.stdout).startswith(f"next: ogacq offsets write {good}")

        explained = ogacq("diagnose", askew, "--history", "none")
        assert last_line(explained.stdout).startswith(
            f"next: ogacq offsets write {askew} --from-diagnosis")

        refused = ogacq("offsets", "write", askew, "--yes", "--history", "none")
        assert refused.returncode == 4
        assert f"`ogacq diagnose {askew}`" in refused.stderr
        # on an 80-column terminal the refusal wraps between words (it was one line)
        code, seen = on_terminal("offsets", "write", askew, "--yes", "--history", "none")
        assert code == 4 and too_wide(seen) == [] and "refused (inconsistent)" in seen

        written = ogacq("offsets", "write", good, "--yes", "--history", "none")
        assert written.returncode == 0, written.stderr
        assert last_line(written.stdout).startswith(
            f"next: ogacq run {campaign} (the validation, recorded as campaign.jsonl")
        assert f"ogacq report {good} --after" in last_line(written.stdout)
