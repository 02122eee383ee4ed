"""The complexity gate counting expressions too (``tools/complexity.py``, radon's
rules): ruff's C901 counts the branches of statements, so logic packed into ``or``
chains and conditional expressions passed it whatever its size. Every function of
ogacq and the drivers is held at or under radon's grade C, but the few named below,
each at most at its figure when the gate came (issue 35): they may shrink, not grow,
and one split under the limit must leave the list."""

from __future__ import annotations

import ast
import sys
import textwrap
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tools"))

from complexity import LIMIT, TREES, blocks, complexity  # noqa: E402

#: (file, function) -> its ceiling: each in a module another change was reworking when
#: the gate came; to be split into named stages as the others were
OVER_THE_LIMIT = {
    ("ogacq/history/plot.py", "history_figure"): 32,
    ("ogacq/cli/wizard/flow.py", "_Wizard._measure"): 27,
    ("ogacq/cli/wizard/gauge_setting.py", "LegSetter._set_and_check"): 24,
    ("ogacq/cli/render.py", "print_session"): 22,
    ("ogacq/diagnose/diagnosis.py", "diagnose"): 22,
}


def test_every_function_is_within_the_limit_counting_its_expressions():
    found = {(b.path, b.name): b for b in blocks(*(ROOT / t for t in TREES))}
    over = [str(b) for key, b in found.items()
            if b.complexity > OVER_THE_LIMIT.get(key, LIMIT)]
    assert over == [], f"split these into named stages (limit {LIMIT}): {over}"
    stale = [key for key, ceiling in OVER_THE_LIMIT.items()
             if key not in found or found[key].complexity <= LIMIT]
    assert stale == [], f"within the limit now, or gone: drop them from the list: {stale}"


def _of(source: str) -> int:
    function = ast.parse(textwrap.dedent(source)).body[0]
    assert isinstance(function, ast.FunctionDef)
    return complexity(function)


def test_expressions_count_as_radon_counts_them():
    # the statements mccabe sees: 1 + if + elif + for + except
    assert _of("""
        def f(x):
            if x:
                return 1
            elif x > 2:
                return 2
            for _ in x:
                pass
            try:
                pass
            except ValueError:
                pass
        """) == 5
    # what it does not: an `or` chain of three (2), a conditional expression (1), a
    # comprehension with its filter (2), an assert (1, its condition not counted)
    assert _of("""
        def g(d, x):
            options = d.get("a") or d.get("b") or {}
            y = 1 if x else 2
            assert x and y
            return [k for k in options if k]
        """) == 7
    # a nested function is a block of its own; a lambda's body is its parent's
    assert _of("""
        def h(x):
            def inner(y):
                return y or x or 0
            return sorted(x, key=lambda k: k if k else 0)
        """) == 2
