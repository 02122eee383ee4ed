"""The fast path (refit and diagnose without typer) held to typer itself: for every
command line it takes, it gives the command's function what typer gives it; it knows
every option typer builds from the same declarations; and it leaves to typer every
line it cannot vouch for, whose messages and exit codes are then typer's."""

from __future__ import annotations

import inspect
import json
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest
import typer

from ogacq.cli import lazy
from ogacq.cli.command_table import COMMANDS, LazyCommandSpec, import_target
from ogacq.cli.fast_path import declared_parameters, fast_call, parse
from ogacq.io.tables import write_readings
from tests.diagnose.campaigns import layout, simulate
from tests.diagnose.test_diagnose_cli import MACHINE_TOML

FAST = {name: spec for name, spec in COMMANDS.items()
        if isinstance(spec, LazyCommandSpec) and spec.fast}

TAKEN = {
    "refit": [
        ["r.csv"],
        ["r.csv", "--machine", "m.toml"],
        ["-m", "m.toml", "r.csv"],
        ["r.csv", "--machine=m.toml", "--json"],
        ["--params", "both", "r.csv", "--method", "exact", "--weighting", "gls"],
        ["r.csv", "--params=lengths", "--method=linear", "--weighting=ols"],
        ["--json", "r.csv", "--other-geometry", "--partial", "--accept-edited"],
        ["--machine", "m.toml", "--", "r.csv"],
        ["--", "-odd name.csv"],
    ],
    "diagnose": [
        ["r.csv"],
        ["r.csv", "-m", "m.toml", "--json"],
        ["r.csv", "--history", "h.sqlite", "--partial"],
        ["r.csv", "--history=postgresql://me@localhost/ogacq", "--accept-edited"],
        ["--other-geometry", "--machine", "m.toml", "r.csv"],
    ],
}

LEFT_TO_TYPER = [
    ["--help"], ["r.csv", "--help"], ["r.csv", "-h"],
    [], ["r.csv", "other.csv"],
    ["r.csv", "--no-such-option"], ["r.csv", "--json=1"], ["r.csv", "--json", "--json"],
    ["r.csv", "--machine"], ["r.csv", "--machine", "--json"], ["r.csv", "-m", "a", "-m", "b"],
    ["r.csv", "-mm.toml"], ["r.csv", "-m=m.toml"], ["-"], ["r.csv", "--machine", ""],
    ["r.csv", "--params", "all"], ["r.csv", "--params", "OFFSETS"],
]


def _plain_function(name: str) -> Any:
    return import_target(FAST[name].target)


def typer_keywords(name: str, words: list[str]) -> dict[str, Any]:
    """What typer's command, built as the app builds it, passes to the function."""
    seen: dict[str, Any] = {}
    declared = lazy.with_typer_declarations(_plain_function(name))

    def record(**keywords: Any) -> None:
        seen.update(keywords)

    record.__signature__ = inspect.signature(declared)  # type: ignore[attr-defined]
    record.__annotations__ = dict(declared.__annotations__)
    record.__doc__ = declared.__doc__
    single = typer.Typer(add_completion=False, rich_markup_mode=None)
    lazy._command(single, name, record, None)
    command = typer.main.get_command(single)
    command.main(args=words, prog_name=f"ogacq {name}", standalone_mode=False)
    return seen


def test_both_commands_are_fast():
    assert set(FAST) == {"refit", "diagnose"}
    for name in FAST:
        assert declared_parameters(_plain_function(name)) is not None, name


@pytest.mark.parametrize("name,words", [(n, w) for n, lines in TAKEN.items() for w in lines])
def test_taken_lines_give_what_typer_gives(name, words):
    fast = parse(declared_parameters(_plain_function(name)), words)
    assert fast is not None, words
    assert fast == typer_keywords(name, words)
    assert {type(v) for v in fast.values()} == \
        {type(v) for v in typer_keywords(name, words).values()}


@pytest.mark.parametrize("name", sorted(FAST))
def test_every_option_typer_builds_is_known(name):
    declared = lazy.with_typer_declarations(_plain_function(name))
    single = typer.Typer(add_completion=False, rich_markup_mode=None)
    lazy._command(single, name, declared, None)
    command = typer.main.get_command(single)
    typer_names = {opt for p in command.params if p.param_type_name == "option"
                   for opt in (*p.opts, *p.secondary_opts)}
    typer_flags = {opt for p in command.params if getattr(p, "is_flag", False)
                   for opt in p.opts}
    parameters = declared_parameters(_plain_function(name))
    fast_names = {n for p in parameters for n in p.option_names}
    fast_flags = {n for p in parameters if p.kind is bool for n in p.option_names}
    assert fast_names == typer_names
    assert fast_flags == typer_flags
    typer_arguments = [p.name for p in command.params if p.param_type_name == "argument"]
    assert [p.name for p in parameters if not p.option_names] \
        == typer_arguments
    for param in command.params:  # the same choices
        choices = getattr(getattr(param, "type", None), "choices", None)
        if choices is not None:
            ours = next(p for p in parameters if p.name == param.name)
            assert sorted(str(m.value) for m in ours.kind) == sorted(map(str, choices))


@pytest.mark.parametrize("name", sorted(FAST))
@pytest.mark.parametrize("words", LEFT_TO_TYPER)
def test_lines_it_cannot_vouch_for_go_to_typer(name, words):
    assert parse(declared_parameters(_plain_function(name)), words) is None
    assert fast_call([name, *words]) is None


def test_the_root_options_and_the_environment(monkeypatch):
    assert fast_call(["refit", "r.csv"]) is not None
    assert fast_call(["-v", "--log-file", "l.log", "refit", "r.csv"]) is not None
    assert fast_call(["--log-file=l.log", "refit", "r.csv"]) is not None
    for front in (["--version"], ["--log-file"], ["--install-completion"],
                  ["--log-file", "a", "--log-file", "b"]):
        assert fast_call([*front, "refit", "r.csv"]) is None, front
    for other in (["run", "c.toml"], ["history", "M"], ["offsets", "show"]):
        assert fast_call(other) is None
    monkeypatch.setenv("OGACQ_NO_FAST_PATH", "1")
    assert fast_call(["refit", "r.csv"]) is None
    monkeypatch.delenv("OGACQ_NO_FAST_PATH")
    monkeypatch.setenv("_OGACQ_COMPLETE", "complete_bash")
    assert fast_call(["refit", "r.csv"]) is None


@pytest.fixture(scope="module")
def files(tmp_path_factory) -> Path:
    root = tmp_path_factory.mktemp("fast")
    (root / "m.toml").write_text(MACHINE_TOML)
    obs = simulate({"squareness.xy": 0.4}, 1, lay=layout(cycles=1))
    write_readings(root / "r.csv", obs.layout, obs.values)
    return root


def ogacq(root: Path, *words: str, slow: bool = False) -> subprocess.CompletedProcess[str]:
    env = {k: v for k, v in __import__("os").environ.items() if k != "OGACQ_NO_FAST_PATH"}
    if slow:
        env["OGACQ_NO_FAST_PATH"] = "1"
    return subprocess.run([sys.executable, "-X", "importtime", "-m", "ogacq", *words],
                          cwd=root, capture_output=True, text=True, env=env, timeout=120)


def modules(stderr: str) -> set[str]:
    return {line.split("|")[-1].strip() for line in stderr.splitlines()
            if line.startswith("import time:")}


@pytest.mark.parametrize("words", [
    ("refit", "r.csv", "--machine", "m.toml", "--json"),
    ("diagnose", "r.csv", "-m", "m.toml", "--json"),
    ("refit", "r.csv", "-m", "m.toml", "--params", "both", "--method", "linear"),
    ("refit", "missing.csv", "-m", "m.toml"),
    ("diagnose", "r.csv", "-m", "r.csv"),
    ("refit", "r.csv", "-m", "m.toml", "--json", "--log-file", "no/such/folder/run.log"),
])
def test_the_same_output_without_typer(files, words):
    fast, slow = ogacq(files, *words), ogacq(files, *words, slow=True)
    assert not {m for m in modules(fast.stderr) if m.split(".")[0] in ("typer", "click")}
    assert {m for m in modules(slow.stderr) if m.split(".")[0] == "typer"}
    assert (fast.returncode, fast.stdout) == (slow.returncode, slow.stdout)
    said = [line for line in fast.stderr.splitlines() if not line.startswith("import time")]
    assert said == [line for line in slow.stderr.splitlines()
                    if not line.startswith("import time")]
    if words[-1] == "--json":
        assert json.loads(fast.stdout)["parameters"]["joint_offset"]


def test_global_options_after_the_command_on_the_fast_path(files):
    log = files / "run.log"
    done = ogacq(files, "refit", "r.csv", "-m", "m.toml", "--json", "--log-file", str(log),
                 "-v")
    assert done.returncode == 0, done.stderr
    assert not {m for m in modules(done.stderr) if m.split(".")[0] == "typer"}
    assert log.exists()
