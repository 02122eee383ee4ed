"""ruff over the checkout finds nothing, with the rules of pyproject's [tool.ruff]:
among them C901, which holds every function of ogacq and the drivers under a
cyclomatic complexity (a hot spot is split into stages, not let grow)."""

from __future__ import annotations

import subprocess
import sys
import textwrap
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
MOST_COMPLEX = 15  # the limit may be lowered in pyproject, never raised past this


def ruff(*args: str, stdin: str | None = None) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "ruff", *args], cwd=ROOT, input=stdin,
                          capture_output=True, text=True, timeout=300)


def test_the_checkout_is_ruff_clean():
    done = ruff("check", "--no-cache", ".")
    assert done.returncode == 0, done.stdout + done.stderr


def test_the_complexity_guard_is_on():
    lint = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["ruff"]["lint"]
    assert "C901" in lint.get("select", []) + lint.get("extend-select", [])
    assert lint["mccabe"]["max-complexity"] <= MOST_COMPLEX
    assert not any("C901" in rules for where, rules in lint.get("per-file-ignores", {}).items()
                   if where.startswith(("ogacq", "drivers")))


def test_a_function_past_the_limit_is_refused():
    limit = tomllib.loads((ROOT / "pyproject.toml").read_text())[
        "tool"]["ruff"]["lint"]["mccabe"]["max-complexity"]
    # one branch per `if`: complexity limit + 1
    branches = "".join(f"    if x == {k}:\n        return {k}\n" for k in range(limit))
    source = f"def tangled(x: int) -> int:\n{branches}    return -1\n"
    done = ruff("check", "--no-cache", "--stdin-filename", "ogacq/tangled.py", "-",
                stdin=source)
    assert done.returncode == 1 and "C901" in done.stdout, done.stdout + done.stderr
    simple = textwrap.dedent("""\
        def plain(x: int) -> int:
            return x + 1
        """)
    assert ruff("check", "--no-cache", "--stdin-filename", "ogacq/plain.py", "-",
                stdin=simple).returncode == 0
