"""Every public JSON output against its golden file, so that a refactor cannot change
one silently (issue 28): a session as a seeded simulated campaign writes it (the
header and each record kind), ``record.json`` (docs/calibration-record.md),
``ogacq diagnose --json`` and ``ogacq refit --json`` (../shared/spec/INTERCHANGE.md).

The inputs are fixed: ``session.jsonl`` (a seeded simulated campaign as ``ogacq run``
wrote it, its start time, date, campaign path and ports replaced, sealed again),
``session-context.jsonl`` (the same campaign recording its context: identity,
certificates, temperatures, an override; tests/record/sessions.py) and the papers'
example data (ogacq/examples/paper). What is compared, and to what tolerance:
tests/golden/compare.py. The live campaign (one ``ogacq run``, a few seconds) is
compared with ``session.jsonl`` by its structure and by what its seed fixes: the
same records in the same order, the header as written, the readings within ten
times the gauge noise and the identified offsets within ten times their std (the
simulated gauges are read in real time, so a reading's noise and drift are not
the seed's alone).

Regenerate (only when an output is meant to change; say what and why in the
commit): ``python -m tests.golden.test_public_json --write`` from the repository's
root. It runs the campaign again, so every golden file changes with it.
"""

from __future__ import annotations

import json
import os
import re
import sys
import tempfile
from pathlib import Path
from typing import Any

import pytest

from ogacq.cli.app import main
from ogacq.session.store import sealed_bytes
from tests.golden.compare import compare, kind

GOLDEN = Path(__file__).resolve().parent
ROOT = GOLDEN.parents[1]
PAPER = ROOT / "ogacq" / "examples" / "paper"
SESSION = GOLDEN / "session.jsonl"
CONTEXT_SESSION = GOLDEN / "session-context.jsonl"
RECORDS = GOLDEN / "record.json"  # {"session": ..., "session-context": ...}
DIAGNOSE = GOLDEN / "diagnose.json"
REFIT = GOLDEN / "refit.json"

CREATED = "2026-01-10T08:58:41+0000"  # the campaign's start, as a session writes it
DATE = "2026-01-10T08:58:41"
PORT = "PORT"

# what ogacq diagnose / refit --json are run on: (name, argv after the command)
PAPER_MACHINE = ["--machine", str(PAPER / "machine.toml")]
DIAGNOSE_CASES = {
    "session": [str(SESSION)],
    "paper experiment2_12": [str(PAPER / "experiment2_12.csv"), *PAPER_MACHINE],
}
REFIT_CASES = {
    "session": [str(SESSION)],
    "session both exact gls": [str(SESSION), "--params", "both", "--method", "exact",
                               "--weighting", "gls"],
    "paper experiment1_6 offsets": [str(PAPER / "experiment1_6.csv"), *PAPER_MACHINE],
    "paper experiment3_12 both linear": [str(PAPER / "experiment3_12.csv"), *PAPER_MACHINE,
                                         "--params", "both", "--method", "linear"],
    "paper experiment2_6 lengths": [str(PAPER / "experiment2_6.csv"), *PAPER_MACHINE,
                                    "--params", "lengths"],
}
# the record's issue time, where its sessions were when it was issued, how long its
# Monte-Carlo check took
RECORD_UNFIXED = frozenset({"issued", "path", "seconds"})


# --- the session -----------------------------------------------------------------

def session_lines(path: Path) -> list[dict[str, Any]]:
    """A session's lines as written, its start, date, campaign path and ports replaced
    by fixed ones (the seals dropped: ``sealed_bytes`` computes them again)."""
    lines = [json.loads(line) for line in path.read_text(encoding="utf-8").splitlines()]
    header = lines[0]
    header.update(created=CREATED, date=DATE, campaign_file="campaign.toml",
                  machine_file="machine.toml")
    station = header["station"]
    controller = station["controller"]
    controller["port"] = re.sub(r":\d+$", f":{PORT}", controller["port"])
    ports = {gauge["port"] for gauge in station["gauges"].values()}
    for gauge in station["gauges"].values():
        gauge["port"] = PORT
    for line in lines:
        for key in ("seq", "prev", "crc"):
            line.pop(key, None)
        if isinstance(line.get("source"), str):
            # the longest first: /dev/pts/4 is the start of /dev/pts/45 ("PORT5")
            for port in sorted(ports, key=len, reverse=True):
                line["source"] = line["source"].replace(port, PORT)
    return lines


def test_a_campaign_writes_the_session_it_wrote(tmp_path):
    """A seeded simulated campaign's session: the header and every record kind."""
    from tests.record.sessions import run_campaign

    golden = session_lines(SESSION)
    written = session_lines(run_campaign(tmp_path / "campaign"))
    assert [line["type"] for line in written] == [line["type"] for line in golden]

    problems = compare(golden[0], written[0], "header")
    result = next(line for line in golden if line["type"] == "result")
    noise = result["noise_mm"]
    std = max(result["refit"]["std"]["joint_offset"].values())

    def loose(path: tuple[str, ...]) -> float | None:
        """Where the real-time reading, not the arithmetic, sets a difference."""
        if path[0] in ("reading_mm", "averaged_sd_mm"):  # the values, and their scatter
            return 10 * noise
        if path[:2] in (("refit", "parameters"), ("refit", "std")):
            return 10 * std
        if path[-1] in ("noise_mm", "sigma_mm", "residual_rms_mm"):
            return 0.6 * noise  # dof ~60: a scatter estimate within ~10 % (1 sigma)
        if path[-1] == "condition_number":
            return 0.01
        return None

    # when each record was written, how long a settle waited, the frame the gauge sent;
    # the checksum of the profile file (its content is the driver's, not the campaign's);
    # how many values a reading averaged, which is how its settle ended
    timing = frozenset({"wall", "t_s", "waited_s", "raw", "profile_sha256", "averaged"})
    settle_keys = {key: kind(line[key]) for line in golden if line["type"] == "settle"
                   for key in line}
    for k, (expected, actual) in enumerate(zip(golden[1:], written[1:], strict=True), 1):
        where = f"line {k + 1} ({expected['type']})"
        if expected["type"] == "settle":
            # how a settle ended depends on the moments the gauges were read: its
            # keys and their types, the step and the rule
            problems += [f"{where}: {key} not a settle's key or not a {settle_keys.get(key)}"
                         for key, value in actual.items()
                         if settle_keys.get(key) != kind(value)]
            actual = {key: actual[key] for key in ("type", "step", "rule")}
            expected = {key: expected[key] for key in ("type", "step", "rule")}
        problems += compare(expected, actual, where, typed_only=timing, loose=loose)
    assert not problems, "\n".join(problems[:20])


# --- record.json, diagnose --json, refit --json ---------------------------------------

def issued_record(session: Path, out: Path) -> dict[str, Any]:
    """The record.json ``ogacq report`` issues for ``session`` (with no history: the
    caller's data folder is empty, and named as ``$OGACQ_HOME``)."""
    assert main(["report", str(session), "--out", str(out)]) == 0
    record = json.loads((out / "record.json").read_text(encoding="utf-8"))
    return replaced(record, os.environ["OGACQ_HOME"], "$OGACQ_HOME")


def replaced(value: Any, old: str, new: str) -> Any:
    """``value`` with ``old`` replaced by ``new`` in every string it holds."""
    if isinstance(value, str):
        return value.replace(old, new)
    if isinstance(value, dict):
        return {key: replaced(item, old, new) for key, item in value.items()}
    if isinstance(value, list):
        return [replaced(item, old, new) for item in value]
    return value


def printed_json(argv: list[str], capsys: pytest.CaptureFixture[str]) -> Any:
    capsys.readouterr()
    assert main([*argv, "--json"]) == 0
    return json.loads(capsys.readouterr().out)


def golden(path: Path) -> dict[str, Any]:
    return json.loads(path.read_text(encoding="utf-8"))


@pytest.mark.parametrize("name", ["session", "session-context"])
def test_record_json_unchanged(name, tmp_path):
    session = SESSION if name == "session" else CONTEXT_SESSION
    record = issued_record(session, tmp_path / name)
    problems = compare(golden(RECORDS)[name], record, "record", typed_only=RECORD_UNFIXED)
    assert not problems, "\n".join(problems[:20])


@pytest.mark.parametrize("name", sorted(DIAGNOSE_CASES))
def test_diagnose_json_unchanged(name, capsys):
    problems = compare(golden(DIAGNOSE)[name],
                       printed_json(["diagnose", *DIAGNOSE_CASES[name]], capsys), "diagnose")
    assert not problems, "\n".join(problems[:20])


@pytest.mark.parametrize("name", sorted(REFIT_CASES))
def test_refit_json_unchanged(name, capsys):
    problems = compare(golden(REFIT)[name],
                       printed_json(["refit", *REFIT_CASES[name]], capsys), "refit")
    assert not problems, "\n".join(problems[:20])


def test_every_case_is_checked():
    """A case added above without regenerating the files would pass unchecked."""
    assert sorted(golden(DIAGNOSE)) == sorted(DIAGNOSE_CASES)
    assert sorted(golden(REFIT)) == sorted(REFIT_CASES)
    assert sorted(golden(RECORDS)) == ["session", "session-context"]


# --- regeneration ----------------------------------------------------------------

def _write() -> None:
    import contextlib
    import io

    from tests.record.sessions import run_campaign, with_context

    with tempfile.TemporaryDirectory() as folder:
        os.environ["OGACQ_HOME"] = str(Path(folder) / "home")  # no history of the user's
        lines = session_lines(run_campaign(Path(folder) / "campaign"))
        SESSION.write_bytes(sealed_bytes(lines[0], lines[1:]))
        CONTEXT_SESSION.unlink(missing_ok=True)
        with_context(SESSION, CONTEXT_SESSION)
        records = {}
        for name, session in (("session", SESSION), ("session-context", CONTEXT_SESSION)):
            os.environ["OGACQ_HOME"] = str(Path(folder) / f"home-{name}")  # no history
            records[name] = issued_record(session, Path(folder) / name)

        def printed(argv: list[str]) -> Any:
            out = io.StringIO()
            with contextlib.redirect_stdout(out):
                assert main([*argv, "--json"]) == 0
            return json.loads(out.getvalue())

        outputs = {DIAGNOSE: {k: printed(["diagnose", *v]) for k, v in DIAGNOSE_CASES.items()},
                   REFIT: {k: printed(["refit", *v]) for k, v in REFIT_CASES.items()},
                   RECORDS: records}
    for path, value in outputs.items():
        path.write_text(json.dumps(value, indent=1) + "\n", encoding="utf-8")
    print(f"wrote {SESSION.name}, {CONTEXT_SESSION.name}, "
          + ", ".join(path.name for path in outputs) + f" in {GOLDEN}")


if __name__ == "__main__":
    if sys.argv[1:] != ["--write"]:
        sys.exit(__doc__)
    _write()
