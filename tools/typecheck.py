"""mypy over both source trees, each under the name it is imported by.

The folder ``drivers/`` installs as the package ``ogacq_drivers`` (pyproject's
``package-dir``), and mypy cannot follow setuptools' editable-install finder, so
``mypy ogacq drivers`` sees ``drivers.errors`` where the code imports
``ogacq_drivers.errors``. This script hands mypy every file of both trees with
its import name, read from ``[tool.setuptools]`` (``packages``, ``package-dir``),
and the options of ``[tool.mypy]``. tests/test_types.py runs it, so the suite
fails on any error::

    python tools/typecheck.py                       # everything: exit 0 when clean
    python tools/typecheck.py ogacq/protocol drivers/link.py   # only their errors
    python tools/typecheck.py /tmp/try.py           # a file of neither tree, checked with them

Paths narrow what is reported, not what is checked: every module is analysed (the
cache, ``.mypy_cache``, makes a second run take seconds). A Python file outside the
trees is added to the check, as a module named by its file name and path.
"""

from __future__ import annotations

import hashlib
import sys
import tomllib
from pathlib import Path

from mypy import build
from mypy.errors import CompileError
from mypy.main import process_options
from mypy.modulefinder import BuildSource

ROOT = Path(__file__).resolve().parents[1]
PYPROJECT = ROOT / "pyproject.toml"


def source_trees(pyproject: Path = PYPROJECT) -> dict[str, Path]:
    """Each top-level package of the distribution -> its folder (relative to the
    project root), as setuptools maps them."""
    setuptools = tomllib.loads(pyproject.read_text())["tool"]["setuptools"]
    folders: dict[str, str] = setuptools.get("package-dir", {})
    tops = sorted({name.split(".")[0] for name in setuptools["packages"]})
    return {top: Path(folders.get(top, top)) for top in tops}


def build_sources(root: Path = ROOT) -> list[BuildSource]:
    """Every module of every tree, named as it is imported."""
    sources = []
    for package, folder in source_trees(root / "pyproject.toml").items():
        for path in sorted((root / folder).rglob("*.py")):
            parts = [package, *path.relative_to(root / folder).with_suffix("").parts]
            if parts[-1] == "__init__":
                parts.pop()
            sources.append(BuildSource(str(path.relative_to(root)), ".".join(parts)))
    return sources


def check(only: list[str] | None = None) -> tuple[list[str], int]:
    """mypy's messages (restricted to files under ``only``, when given) and the count
    of source files checked. Run from the project root (paths are relative to it)."""
    _, options = process_options(["--config-file", str(PYPROJECT), "-c", "pass"])
    sources = build_sources()
    trees = [ROOT / folder for folder in source_trees().values()]
    for given in map(Path, only or ()):
        inside = any(given.resolve().is_relative_to(tree) for tree in trees)
        if given.suffix == ".py" and given.is_file() and not inside:
            # named after its path too: mypy's cache knows a module by its name, and
            # would replay the errors of a same-named file elsewhere under that path
            where = hashlib.sha1(str(given.resolve()).encode()).hexdigest()[:12]
            sources.append(BuildSource(str(given), f"{given.stem}_{where}"))
    try:
        messages = build.build(sources, options).errors
    except CompileError as exc:  # a syntax error or a blocking one: reported as it is
        messages = list(exc.messages)
    if only:
        prefixes = tuple(str(Path(p)) for p in only)
        messages = [m for m in messages if m.startswith(prefixes)]
    return messages, len(sources)


def main(argv: list[str]) -> int:
    messages, checked = check(argv or None)
    for message in messages:
        print(message)
    errors = [m for m in messages if ": error: " in m]
    files = {m.split(":", 1)[0] for m in errors}
    if errors:
        print(f"Found {len(errors)} error{'s' * (len(errors) != 1)} in {len(files)} "
              f"file{'s' * (len(files) != 1)} (checked {checked} source files)")
        return 1
    print(f"Success: no issues found in {checked} source files")
    return 0


if __name__ == "__main__":
    import os

    os.chdir(ROOT)
    sys.exit(main(sys.argv[1:]))
