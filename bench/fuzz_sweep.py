"""Sweep: the corruption and input-fuzz trials of issue 26, with their counts (prints
figures; not a test). What is recorded must be whole and true: no traceback, and no
silent change -- a result that differs from the untouched one while the output says
nothing of an edit or of a partial campaign, or a nonsense number accepted.

1. Session corruption, on one simulated campaign (``ogacq run``, 72 readings):
   every reading moved by 0.05 mm with its crc deleted (and its seq, and its prev),
   the header's leg length changed without its crc, every record deleted, every cut
   at a line boundary, every line doubled, neighbours swapped, random bit flips.
   Each case through ``ogacq refit --json`` as a user runs it, then with
   ``--partial --accept-edited`` (the output must then say what it analysed).
2. Input fuzz: tokens no CSV or TOML number should be (fullwidth and Arabic-Indic
   digits, ``1_000``, 40-digit integers, 1e308, inf, nan, hex, ...) and ones it may
   be, in random cells of a readings CSV and a deviations CSV (``ogacq refit``), and
   in every number of the machine, campaign and effects files (their readers).
   The judge of which token is a number is written here, from the CSV and TOML
   grammars, not taken from ogacq.
3. History: malformed URLs through every command that takes one; bit flips in an
   SQLite history, then ``history add`` (an added calibration must read back).
4. Recorded text with markup, an emoji code and a terminal escape, printed by
   every command that prints it.

Counts: per family, outcome -> cases; then "tracebacks N, silent changes N". Exit 1
when either is not 0. About 3 minutes on 2 cores (``--quick``: about 1).

Run: python bench/fuzz_sweep.py [--seed N] [--flips 200] [--fuzz 1500] [--quick]
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import random
import re
import shutil
import sqlite3
import subprocess
import sys
import tempfile
import time
import traceback
from collections import Counter
from pathlib import Path

from ogacq.cli.app import main

MACHINE = """name = "Cell [/3]"
serial = "SN-1"
leg_length_mm = 310.25
rho_min_mm = -100.0
rho_max_mm = 60.0
gauge_resolution_mm = 0.001
"""
CAMPAIGN = """machine = "machine.toml"
session = "session.jsonl"
operator = "J. [/x] Martin :x: \\u001b[2J"

[simulator]
seed = 3
speed = 100

[protocol]
settle_s = 0.5
"""
PAPER = Path(__file__).resolve().parents[1] / "ogacq" / "examples" / "paper"

tracebacks: list[str] = []
silent: list[str] = []


# ------------------------------------------------------------------------- running ogacq

def ogacq(*args: object) -> tuple[int | None, str, str]:
    """``ogacq ARGS`` in this process: (exit code, stdout, stderr); exit None when an
    exception escaped the command line (a traceback a user would see)."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            code = main([str(a) for a in args])
        except SystemExit as exc:
            code = exc.code if isinstance(exc.code, int) else 1
        except BaseException:  # noqa: BLE001 -- what the user would see as a traceback
            return None, out.getvalue(), traceback.format_exc()
    return code, out.getvalue(), err.getvalue()


def one_line(text: str) -> bool:
    return len(text.strip().splitlines()) == 1 and "Traceback" not in text


# ------------------------------------------------------------------------- 1. sessions

def record_campaign(folder: Path) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "machine.toml").write_text(MACHINE)
    (folder / "campaign.toml").write_text(CAMPAIGN)
    done = subprocess.run([sys.executable, "-m", "ogacq", "run", str(folder / "campaign.toml"),
                           "--json", "--history", "none"], capture_output=True, text=True,
                          timeout=300)
    if done.returncode != 0:
        sys.exit(f"the campaign did not run: {done.stderr}")
    return folder / "session.jsonl"


def offsets(stdout: str) -> tuple[float, ...]:
    found = json.loads(stdout)["parameters"]["joint_offset"]
    return tuple(found[a] for a in "xyz")


def says_what_it_is(stdout: str) -> bool:
    data = json.loads(stdout)
    return "edited" in data or "partial" in data or data.get("integrity") not in (None,
                                                                               "sealed")


def judge_session(family: str, data: bytes, path: Path, baseline: tuple[float, ...],
                  counts: Counter) -> None:
    """One corrupted session through refit, as a user runs it and with the flags that
    take it as it stands."""
    path.write_bytes(data)
    # an ogacq before issue 26 has not the flags: its default run is all there is to judge
    for flags in ((), ("--partial", "--accept-edited"))[:2 if options_known() else 1]:
        code, out, err = ogacq("refit", path, "--json", *flags)
        label = "as it stands" if flags else "default"
        if code is None:
            tracebacks.append(f"{family} ({label}): {err.strip().splitlines()[-1]}")
            counts[f"{label}: traceback"] += 1
            continue
        if code != 0:
            counts[f"{label}: refused in one line" if one_line(err)
                   else f"{label}: refused in several lines"] += 1
            if not one_line(err):
                silent.append(f"{family} ({label}): not one line: {err[:200]!r}")
            continue
        try:
            same = offsets(out) == baseline
        except (ValueError, KeyError, TypeError):
            silent.append(f"{family} ({label}): exit 0 without its JSON")
            continue
        if same:
            counts[f"{label}: the untouched result"] += 1
        elif says_what_it_is(out):
            counts[f"{label}: another result, said (partial/edited)"] += 1
        else:
            counts[f"{label}: SILENT CHANGE"] += 1
            silent.append(f"{family} ({label}): a changed result, nothing said")


_KNOWN: list[bool] = []


def options_known() -> bool:
    """Whether this ogacq has --partial and --accept-edited (issue 26)."""
    if not _KNOWN:
        _KNOWN.append("--accept-edited" in ogacq("refit", "--help")[1])
    return _KNOWN[0]


def session_cases(raw: bytes, rng: random.Random, flips: int) -> list[tuple[str, bytes]]:
    lines = raw.split(b"\n")[:-1]
    records = [json.loads(line) for line in lines]
    readings = [k for k, r in enumerate(records) if r.get("type") == "reading"]
    joined = lambda ls: b"\n".join(ls) + b"\n"  # noqa: E731
    cases = []
    for deleted in (("crc",), ("crc", "seq"), ("crc", "seq", "prev")):
        for k in readings:
            r = dict(records[k])
            r["reading_mm"] = round(r["reading_mm"] + 0.05, 6)
            for key in deleted:
                r.pop(key, None)
            cases.append((f"reading moved, {'+'.join(deleted)} deleted",
                          joined([*lines[:k], json.dumps(r, separators=(",", ":")).encode(),
                                  *lines[k + 1:]])))
    header = dict(records[0])
    header["machine"] = {**header["machine"], "leg_length_mm": 300.0}
    header.pop("crc", None)
    cases.append(("header leg length changed, crc deleted",
                  joined([json.dumps(header, separators=(",", ":")).encode(), *lines[1:]])))
    for k in range(1, len(lines)):
        cases.append(("a record deleted", joined(lines[:k] + lines[k + 1:])))
        cases.append(("a line doubled", joined(lines[:k + 1] + lines[k:])))
    for k in range(1, len(lines) - 1):
        cases.append(("neighbours swapped", joined([*lines[:k], lines[k + 1], lines[k],
                                                    *lines[k + 2:]])))
    for k in range(1, len(lines)):
        cases.append(("cut at a line boundary", joined(lines[:k])))
    for _ in range(flips):
        flipped = bytearray(raw)
        at = rng.randrange(len(raw))
        flipped[at] ^= 1 << rng.randrange(7)
        cases.append(("a bit flipped", bytes(flipped)))
    return cases


def sweep_sessions(session: Path, work: Path, rng: random.Random, flips: int) -> None:
    code, out, err = ogacq("refit", session, "--json")
    if code != 0:
        sys.exit(f"refit of the untouched session failed: {err}")
    baseline = offsets(out)
    by_family: dict[str, Counter] = {}
    for family, data in session_cases(session.read_bytes(), rng, flips):
        judge_session(family, data, work / "case.jsonl", baseline,
                      by_family.setdefault(family, Counter()))
    report("1. session corruption (refit --json)", by_family)


# ------------------------------------------------------------------------- 2. input fuzz

# Tokens, and whether a number field may take them: judged here from the grammars.
NOT_NUMBERS = ["１２", "١٢", "1_000", "9" * 40, "-" + "9" * 40, "1e308", "-1e308", "inf",
               "-inf", "nan", "0x10", "", " ", "1,5", '"1,5"', "１.５", "12abc", "+-1", "−1", "1e",
               ".", "--1", "1e5000", "9" * 400, "1.2.3", "٫5", "NaN", "Infinity"]
NUMBERS = ["0", "1", "-1", "0.5", "+2.5", "1e-3", "12.000", " 3 ", "1E2", ".5", "5."]
CSV_NUMBER = re.compile(r"[ \t]*[+-]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?[ \t]*")


def csv_number_ok(token: str, bound: float) -> bool:
    """A CSV number: ASCII digits with a sign, a point, an exponent, finite, within a
    physical bound (1e5 mm; 1e9 s)."""
    if not CSV_NUMBER.fullmatch(token):
        return False
    value = float(token)
    return value == value and abs(value) <= bound


def fuzz_csv(path: Path, work: Path, machine: Path | None, rng: random.Random, n: int,
             counts: Counter, kind: str) -> None:
    lines = path.read_text().splitlines()
    header = lines[0].split(",")
    numeric = [c for c, name in enumerate(header) if name not in ("leg", "gauge_axis", "name",
                                                                  "cycle")]
    for _ in range(n):
        token = rng.choice(NOT_NUMBERS + NUMBERS)
        row = rng.randrange(1, len(lines))
        column = rng.choice(numeric + ([header.index("cycle")] if "cycle" in header else []))
        cells = lines[row].split(",")
        cells[column] = token
        target = work / f"fuzz-{kind}.csv"
        target.write_text("\n".join([*lines[:row], ",".join(cells), *lines[row + 1:]]) + "\n")
        args = ["refit", target, "--json"] + (["-m", machine] if machine else [])
        code, out, err = ogacq(*args)
        name = header[column]
        if name == "cycle":
            fine = token.strip().isascii() and token.strip().isdigit() and \
                1 <= int(token.strip()) <= 10**6
        elif name.startswith("approach"):
            fine = CSV_NUMBER.fullmatch(token) is not None and float(token) in (-1.0, 0.0, 1.0)
        else:
            fine = csv_number_ok(token, 1e9 if name == "t_s" else 1e5)
        judge_input(f"{kind} {name}={token!r}", code, err, fine, counts)


def judge_input(case: str, code: int | None, err: str, fine: bool, counts: Counter) -> None:
    if code is None:
        tracebacks.append(f"{case}: {err.strip().splitlines()[-1]}")
        counts["traceback"] += 1
    elif code == 0 and not fine:
        counts["NONSENSE ACCEPTED"] += 1
        silent.append(f"{case}: accepted")
    elif code == 0:
        counts["a number, accepted"] += 1
    elif code == 2 and one_line(err):
        counts["refused in one line (exit 2)" if not fine
               else "a number, refused by a later check (exit 2)"] += 1
    else:
        counts[f"exit {code}{'' if one_line(err) else ', not one line'}"] += 1
        if not one_line(err):
            silent.append(f"{case}: not one line: {err[:200]!r}")


TOML_NOT_NUMBERS = ["9" * 40, "-" + "9" * 40, "1e308", "-1e308", "inf", "nan", "-inf",
                    "0x" + "f" * 30, "9" * 5000, "1e30", "-1e30"]
TOML_NUMBERS = ["1", "0.5", "2.0", "1_0", "1e1"]


def fuzz_toml(reader, text: str, work: Path, counts: Counter, kind: str) -> None:
    """Every number of a TOML file replaced by each token; the reader's verdict."""
    from ogacq.errors import OgacqError

    (work / f"{kind}.toml").write_text(text)
    reader(work / f"{kind}.toml")  # the file as given reads: each case changes one number

    for match in re.finditer(r"^(\s*[A-Za-z_.\"]+\s*=\s*)([-+0-9.eE_]+)\s*$", text, re.M):
        for token in TOML_NOT_NUMBERS + TOML_NUMBERS:
            changed = text[:match.start(2)] + token + text[match.end(2):]
            path = work / f"{kind}.toml"
            path.write_text(changed)
            try:
                reader(path)
                code, err = 0, ""
            except OgacqError as exc:
                code, err = 2, str(exc)
            except Exception:  # noqa: BLE001 -- a traceback
                code, err = None, traceback.format_exc()
            # nonsense for any key of these files: beyond 64 bits, not finite, 1e30
            key = match.group(1).split("=")[0].strip()
            judge_input(f"{kind} {key}={token[:20]}", code, err, token in TOML_NUMBERS,
                        counts)


def sweep_inputs(session: Path, work: Path, rng: random.Random, n: int) -> None:
    from ogacq.campaign.campaign_file import read_campaign
    from ogacq.io.machine_file import read_machine
    from ogacq.sim.truth import random_truth, read_effects

    by_family: dict[str, Counter] = {}
    readings = work / "readings.csv"
    if ogacq("session", "export", session, readings)[0] != 0:
        sys.exit("session export failed")
    fuzz_csv(readings, work, session.parent / "machine.toml", rng, n * 2 // 3,
             by_family.setdefault("readings CSV (refit)", Counter()), "readings")
    fuzz_csv(PAPER / "experiment2_12.csv", work, PAPER / "machine.toml", rng, n // 3,
             by_family.setdefault("deviations CSV (refit)", Counter()), "deviations")
    (work / "machine.toml").write_text(MACHINE)
    fuzz_toml(read_machine, MACHINE, work, by_family.setdefault("machine file", Counter()),
              "machine")
    (work / "machine.toml").write_text(MACHINE)  # the campaign below names it: as given
    campaign = ("deadline_s = 600\n" + CAMPAIGN + "[stability]\nreadings = 3\n"
                "tolerance_mm = 0.002\ntimeout_s = 10\n").replace(
        "[protocol]\n", "[protocol]\ncycles = 3\novershoot_mm = 1.0\nsettle_window_s = 0.1\n")
    fuzz_toml(read_campaign, campaign, work, by_family.setdefault("campaign file", Counter()),
              "campaign")
    effects = ("[joint_offset]\nx = 0.4\n[squareness]\nxy = 0.5\n[gauge_scale]\ny_x = 300\n"
               "[gauges]\nnoise_mm = 0.001\n[vibration]\namplitude_mm = 0.01\n"
               "time_constant_s = 0.15\nfrequency_hz = 20.0\n")
    fuzz_toml(lambda p: read_effects(p, random_truth(1)), effects, work,
              by_family.setdefault("effects file", Counter()), "effects")
    report("2. input fuzz", by_family)


# ------------------------------------------------------------------------- 3. history

URLS = ["postgresql://u:pw@host:notaport/db", "postgresql://u:pw@[::1/db",
        "postgresql://u:pw@localhost/db?sslmode=bogus", "postgresql://u:pw@host:0/db",
        "postgresql://u:pw@host:99999/db", "postgresql://u:pw@host/db?foo=bar",
        "postgresql://u:pw@host/db?connect_timeout=soon", "mysql://u:pw@h/db",
        "sqlite://", "sqlite:///:memory:", "postgresql://u:pw@[::1]x/db", "://", "  "]


def readable(history: Path) -> bool:
    """Whether an SQLite file passes its check and every stored JSON document reads
    (sqlite3 and json here, not ogacq)."""
    try:
        with contextlib.closing(sqlite3.connect(history)) as conn:
            conn.text_factory = bytes
            if conn.execute("PRAGMA quick_check").fetchall() != [(b"ok",)]:
                return False
            for row in conn.execute("SELECT verdict, acceptance, instruments, environment, "
                                    "overrides, details, record FROM ogacq_events"):
                for text in row:
                    if text is not None:
                        json.loads(text.decode("utf-8"))
    except (sqlite3.Error, ValueError):
        return False
    return True


def sweep_history(session: Path, work: Path, rng: random.Random, flips: int) -> None:
    by_family: dict[str, Counter] = {}
    counts = by_family.setdefault("malformed URLs x commands", Counter())
    for url in URLS:
        for args, optional in ((["history", "X", "--history", url], False),
                               (["history", "add", session, "--history", url], False),
                               (["offsets", "restore", "--machine", "X", "--to", "Y",
                                 "--history", url], False),
                               (["diagnose", session, "--json", "--history", url], True),
                               (["report", session, "--out", work / "r", "--history", url],
                                True)):
            code, out, err = ogacq(*args)
            case = f"{args[0]} {args[1]} {url!r}"
            if code is None:
                tracebacks.append(f"{case}: {err.strip().splitlines()[-1]}")
                counts["traceback"] += 1
            elif "pw" in out + err:
                counts["PASSWORD SHOWN"] += 1
                silent.append(f"{case}: the password in the output")
            elif code == 0 and optional:
                counts["optional: done, said in a warning"] += 1
            elif code in (2, 3) and one_line(err):
                counts[f"one line, exit {code}"] += 1
            else:
                counts[f"exit {code}, {len(err.splitlines())} lines"] += 1
    counts = by_family.setdefault("SQLite history with bit flips, then history add",
                                  Counter())
    clean = work / "clean.sqlite"
    ogacq("history", "add", session, "--history", clean)
    raw = clean.read_bytes()
    history = work / "flipped.sqlite"
    for _ in range(flips):
        flipped = bytearray(raw)
        for _ in range(20):
            at = rng.randrange(100, len(raw))
            flipped[at] ^= 1 << rng.randrange(8)
        history.write_bytes(bytes(flipped))
        with contextlib.suppress(OSError):
            Path(str(history) + "-journal").unlink()
        healthy = readable(history)
        code, _, err = ogacq("history", "add", session, "--history", history)
        if code is None:
            tracebacks.append(f"history add (flipped): {err.strip().splitlines()[-1]}")
            counts["traceback"] += 1
        elif code == 0 and not healthy:
            counts["WRITTEN INTO A CORRUPT FILE"] += 1
            silent.append("history add accepted a history failing its integrity check")
        elif code == 0:
            read = ogacq("history", "Cell [/3]", "--history", history, "--json")
            if read[0] == 0:
                counts["healthy: recorded, reads back"] += 1
            else:
                counts["RECORDED, DOES NOT READ BACK"] += 1
                silent.append("history add: recorded where it cannot be read back")
        elif one_line(err):
            counts[f"refused in one line (exit {code})"] += 1
        else:
            counts[f"exit {code}, not one line"] += 1
    report("3. history", by_family)


# ------------------------------------------------------------------------- 4. text

def sweep_text(session: Path, work: Path) -> None:
    by_family: dict[str, Counter] = {}
    counts = by_family.setdefault("recorded markup/emoji/escape, printed", Counter())
    history = work / "text.sqlite"
    ogacq("history", "add", session, "--history", history)
    for args in (["session", "show", session], ["session", "check", session],
                 ["history", "Cell [/3]", "--history", history],
                 ["history", "Cell [/3]", "--history", history, "--states"],
                 ["refit", session], ["diagnose", session, "--history", "none"],
                 ["report", session, "--out", work / "text-report", "--history", "none"]):
        code, out, err = ogacq(*args)
        case = " ".join(map(str, args[:2]))
        if code is None:
            tracebacks.append(f"{case}: {err.strip().splitlines()[-1]}")
            counts["traceback"] += 1
        elif "\x1b" in out + err or "❌" in out + err:
            counts["A TERMINAL ESCAPE OR AN EMOJI PRINTED"] += 1
            silent.append(f"{case}: the recorded text was not printed as it is")
        else:
            counts[f"exit {code}, printed as recorded"] += 1
    report("4. recorded text", by_family)


# ------------------------------------------------------------------------- the report

def report(title: str, by_family: dict[str, Counter]) -> None:
    print(f"\n{title}")
    for family, counts in by_family.items():
        total = sum(counts.values())
        print(f"  {family}: {total} cases")
        for outcome, n in sorted(counts.items(), key=lambda kv: -kv[1]):
            print(f"    {n:5d}  {outcome}")
    sys.stdout.flush()


def main_sweep() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seed", type=int, default=26)
    parser.add_argument("--flips", type=int, default=200)
    parser.add_argument("--fuzz", type=int, default=1500)
    parser.add_argument("--quick", action="store_true", help="fewer flips and fuzz cases")
    args = parser.parse_args()
    if args.quick:
        args.flips, args.fuzz = 40, 300
    rng = random.Random(args.seed)
    started = time.monotonic()
    with tempfile.TemporaryDirectory(prefix="ogacq-sweep-") as tmp:
        work = Path(tmp)
        session = record_campaign(work / "runs [/y]")
        print(f"campaign recorded: {session}")
        sweep_sessions(session, work, rng, args.flips)
        sweep_inputs(session, work, rng, args.fuzz)
        sweep_history(session, work, rng, max(args.flips // 10, 10))
        sweep_text(session, work)
        shutil.rmtree(work / "r", ignore_errors=True)
    for line in tracebacks[:20]:
        print(f"traceback: {line}")
    for line in silent[:20]:
        print(f"silent: {line}")
    print(f"\ntracebacks {len(tracebacks)}, silent changes {len(silent)} "
          f"({time.monotonic() - started:.0f} s)")
    return 1 if tracebacks or silent else 0


if __name__ == "__main__":
    sys.exit(main_sweep())
