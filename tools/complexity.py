"""Cyclomatic complexity counted as radon counts it: expressions too.

ruff's C901 (mccabe) counts the branches of statements; logic packed into boolean
operators and conditional expressions (``a or b or {}``, ``x if c else y``) passes it
whatever its size. This counter follows radon 6.0.1's rules
(``radon/visitors.py:ComplexityVisitor``; https://radon.readthedocs.io, "Cyclomatic
Complexity"), so that its figures are radon's without radon installed: a function
starts at 1 and adds

* 1 per ``if``/``elif`` statement and per conditional expression;
* n - 1 per boolean operation of n operands (``a and b or c``: 2);
* 1 per ``for``/``while`` loop, 1 more for its ``else``;
* 1 per ``except`` handler, 1 for a ``try``'s ``else``;
* 1 per comprehension's ``for`` and 1 per its ``if``;
* 1 per ``match`` case but an irrefutable one (``case _``);
* 1 per ``assert``, whatever its condition.

A nested function or class is a block of its own, not part of its parent's figure;
a lambda's body is its parent's. Decorators and default values are not counted.
tests/test_complexity.py holds every block of ogacq and the drivers at or under a
limit::

    python tools/complexity.py                 # blocks over the limit, worst first
    python tools/complexity.py ogacq/cli 15    # under ogacq/cli, over 15
"""

from __future__ import annotations

import ast
import sys
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
TREES = ("ogacq", "drivers")
#: every block of the trees at or under this, but for tests/test_complexity.py's list
LIMIT = 20  # radon's grade C: "moderate" (21-30 is D, "more than moderate")

Definition = ast.FunctionDef | ast.AsyncFunctionDef
Scope = Definition | ast.ClassDef | ast.Lambda


@dataclass(frozen=True)
class Block:
    """One function or method and its complexity."""

    path: str  # relative to the checkout
    name: str  # qualified within its module: Class.method, outer.<locals>.inner
    line: int
    complexity: int

    def __str__(self) -> str:
        return f"{self.path}:{self.line} {self.name} {self.complexity}"


def decisions(node: ast.AST) -> int:
    """The decision points ``node`` itself adds (its children not counted)."""
    if isinstance(node, ast.Try | ast.TryStar):
        return len(node.handlers) + bool(node.orelse)
    if isinstance(node, ast.BoolOp):
        return len(node.values) - 1
    if isinstance(node, ast.If | ast.IfExp | ast.Assert):
        return 1
    if isinstance(node, ast.For | ast.AsyncFor | ast.While):
        return 1 + bool(node.orelse)
    if isinstance(node, ast.comprehension):
        return 1 + len(node.ifs)
    if isinstance(node, ast.Match):
        # an irrefutable case (``case _``, ``case name``) is the match's else
        bare = any(isinstance(c.pattern, ast.MatchAs) and c.pattern.pattern is None
                   for c in node.cases)
        return max(0, len(node.cases) - bare)
    return 0


def _body_decisions(node: ast.AST) -> int:
    """The decision points under ``node``, nested functions and classes left out
    (each is a block of its own)."""
    total = 0
    for child in ast.iter_child_nodes(node):
        if isinstance(child, Definition | ast.ClassDef):
            continue
        # an assert is 1 whatever its condition (radon does not look inside it)
        total += decisions(child) + (0 if isinstance(child, ast.Assert)
                                     else _body_decisions(child))
    return total


def complexity(function: Definition) -> int:
    return 1 + _body_decisions(ast.Module(body=function.body, type_ignores=[]))


def blocks_of(tree: ast.AST, path: str, prefix: str = "") -> Iterator[Block]:
    for node in ast.iter_child_nodes(tree):
        if isinstance(node, Definition):
            name = prefix + node.name
            yield Block(path, name, node.lineno, complexity(node))
            yield from blocks_of(node, path, f"{name}.<locals>.")
        elif isinstance(node, ast.ClassDef):
            yield from blocks_of(node, path, f"{prefix}{node.name}.")
        else:  # a definition under an if, a with or a try is still a block
            yield from blocks_of(node, path, prefix)


def blocks(*roots: Path) -> list[Block]:
    """Every function of the Python files under ``roots``, worst first."""
    files = sorted(f for root in roots for f in ([root] if root.is_file()
                                                  else root.rglob("*.py")))
    found = [block for f in files
             for block in blocks_of(ast.parse(f.read_text(encoding="utf-8"), str(f)),
                                    f.resolve().relative_to(ROOT).as_posix())]
    return sorted(found, key=lambda b: (-b.complexity, b.path, b.line))


def main(argv: list[str]) -> int:
    roots = [Path(a) for a in argv if not a.isdigit()] or [ROOT / t for t in TREES]
    limit = next((int(a) for a in argv if a.isdigit()), LIMIT)
    over = [b for b in blocks(*roots) if b.complexity > limit]
    for block in over:
        print(block)
    return 1 if over else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
