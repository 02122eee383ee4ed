"""ARCHITECTURE.md's picture is the code's: its table of layers names every package
that exists and none that does not, in the layers the imports keep (the same rules
as ``test_layers.py``, checked here against the document's own table, and the two
tables kept equal); and every file, folder and ``file.py:name`` it points a reader
to is there.

Nothing is imported: the document is read as text, the source with ``ast``
(``test_layers.modules``, ``imports_of``).
"""

from __future__ import annotations

import re
from functools import cache
from pathlib import Path

from tests.test_layers import LAYERS, PACKAGES, _a_cycle, imports_of, modules

ROOT = Path(__file__).resolve().parents[1]
DOC = ROOT / "ARCHITECTURE.md"


@cache
def layer_rows() -> list[tuple[tuple[str, ...], str]]:
    """The table under "The layers, lowest first": per row, lowest first, the entries
    (the backticked dotted names of its first cell; anything else there is prose) and
    its "may not import" cell."""
    text = DOC.read_text()
    section = text[text.index("## The layers, lowest first"):]
    section = section[:section.index("\n## ", 1)]
    rows = []
    for line in section.splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if not line.startswith("|") or cells[0] in ("layer", "---") or len(cells) != 3:
            continue
        rows.append((tuple(re.findall(r"`([A-Za-z_][\w.]*)`", cells[0])), cells[2]))
    return rows


def doc_layers() -> list[tuple[str, ...]]:
    return [entries for entries, _ in layer_rows()]


def doc_level() -> dict[str, int]:
    return {e: level for level, entries in enumerate(doc_layers()) for e in entries}


def doc_entry_of(module: str) -> str | None:
    """The document's entry a module belongs to: the longest naming it or a package
    above it (a tree's root package, ``ogacq``, names its __init__ only)."""
    matches = [e for e in doc_level() if module == e or (module.startswith(e + ".")
                                                         and e not in PACKAGES)]
    return max(matches, key=len, default=None)


def test_the_table_is_read():
    """The parser sees the table (a reformatted document fails here, not silently)."""
    rows = doc_layers()
    assert len(rows) >= 10 and rows[0][0] == "ogacq_drivers" and "ogacq.cli" in rows[-1]
    assert all(rows), "a row without a backticked package"


def test_every_package_named_exists_and_every_package_is_named():
    named = [e for entries in doc_layers() for e in entries]
    assert len(named) == len(set(named)), "a package named twice"
    assert not [e for e in named if e not in modules()], "named, but no such module"
    unplaced = sorted(m for m in modules() if doc_entry_of(m) is None)
    assert not unplaced, f"ARCHITECTURE.md's table places no layer for: {unplaced}"
    stale = sorted(e for e in named if not any(doc_entry_of(m) == e for m in modules()))
    assert not stale, f"entries that cover no module (a longer entry takes them all): {stale}"


def test_the_documents_layers_are_the_enforced_ones():
    """Row for row the entries of tests/test_layers.py's LAYERS: one picture."""
    assert [set(row) for row in doc_layers()] == [set(row) for row in LAYERS]


def test_no_module_imports_a_layer_above_its_own_in_the_document():
    level = {m: doc_level()[e] for m in modules() if (e := doc_entry_of(m)) is not None}
    upward = [f"{m} ({doc_entry_of(m)}) imports {t} ({doc_entry_of(t)})"
              for m in sorted(level) for t in sorted(imports_of(m))
              if level.get(t, -1) > level[m]]  # an unplaced module: said by the test above
    assert not upward, "\n".join(upward)


def test_the_packages_of_a_row_import_each_other_one_way():
    edges: dict[str, set[str]] = {e: set() for e in doc_level()}
    for m in modules():
        if (source := doc_entry_of(m)) is not None:
            edges[source].update(t for t in map(doc_entry_of, imports_of(m))
                                 if t is not None and t != source)
    cycle = _a_cycle(edges)
    assert cycle is None, " -> ".join(cycle or [])


def test_what_a_row_may_not_import_lies_above_it():
    """The "may not import" cell names packages of higher rows (``protocol``: ogacq's)."""
    level = doc_level()
    for row, (_, forbidden) in enumerate(layer_rows()):
        if forbidden in ("", "anything of the project"):
            continue
        for name in re.split(r",\s*|\s+and above", forbidden.replace("`", "")):
            if not name:
                continue
            entry = name if name.split(".")[0] in PACKAGES else f"ogacq.{name}"
            assert entry in level, f"row {row} names {name!r}: no such entry"
            assert level[entry] > row, f"row {row} forbids {name!r}, which is not above it"


# A path in backticks: a folder or file of the repository (with a brace list, a
# placeholder <name>, or a ":name" defined in the file).
_PATH = re.compile(r"`((?:ogacq|drivers|tests|bench|docs|tools)/[^`\s]*)`")


def _expanded(path: str) -> list[str]:
    braces = re.search(r"\{([^}]*)\}", path)
    if braces is None:
        return [path]
    return [path[:braces.start()] + part + path[braces.end():]
            for part in braces.group(1).split(",")]


def _defines(path: Path, name: str) -> bool:
    """``name`` (its first part: ``Class.method`` -> ``Class``) is defined at the left
    margin of ``path`` or as a class's attribute or method."""
    first = re.escape(name.split(".")[0])
    return re.search(rf"^\s*(?:def|class)\s+{first}\b|^\s*{first}\s*(?::|=)",
                     path.read_text(), flags=re.M) is not None


def test_every_file_and_name_the_document_points_to_is_there():
    wrong = []
    for token in sorted(set(_PATH.findall(DOC.read_text()))):
        path, _, name = token.partition(":")
        if "<" in path:  # a pattern for a file to add: its folder must be there
            path = path[:path.index("<")].rpartition("/")[0]
        for one in _expanded(path):
            target = ROOT / one
            if not target.exists():
                wrong.append(f"{token}: no {one}")
            elif name and not _defines(target, name):
                wrong.append(f"{token}: {one} defines no {name}")
    assert not wrong, "\n".join(wrong)


def test_the_path_check_sees_a_wrong_path():
    assert _expanded("ogacq/compensation/{linuxcnc,fanuc}.py") == [
        "ogacq/compensation/linuxcnc.py", "ogacq/compensation/fanuc.py"]
    assert _defines(ROOT / "ogacq/history/plot.py", "history_figure")
    assert not _defines(ROOT / "ogacq/history/plot.py", "no_such_function")


# --- "How to add": the common changes, each with the files it touches -----------------------

COMMON_CHANGES = ("A gauge protocol", "A drive profile", "An effect", "A report section",
                  "A command", "A table format", "An error-map family")
_FILES_LINE = "Files to touch:"
# names that are one file wherever they are said: the repository's root files, and a
# file ogacq writes (``record.json`` beside the report)
_ROOT_FILES_AND_OUTPUTS = ("pyproject.toml", "README.md", "record.json")
# a backticked file (a name with an extension, or a folder), full or bare
_FILE_TOKEN = re.compile(r"`([\w./<>{},*-]+(?:\.(?:py|toml|j2|css|md|json)|/))(?::[\w.]+)?`")


@cache
def how_to_add() -> dict[str, str]:
    """The section's paragraphs by their bold title (``**A command.**`` -> "A command"),
    each up to the next title."""
    text = DOC.read_text()
    section = text[text.index("## How to add"):]
    end = section.find("\n## ", 1)
    section = section if end < 0 else section[:end]
    parts = re.split(r"^\*\*([^*]+?)\.?\*\*", section, flags=re.M)
    return {title.split(" (")[0].strip(): body for title, body in zip(parts[1::2], parts[2::2],
                                                                         strict=True)}


def files_to_touch(body: str) -> list[str]:
    """The backticked paths of a paragraph's "Files to touch:" list."""
    assert body.count(_FILES_LINE) == 1, "one 'Files to touch:' list per change"
    listed = body[body.index(_FILES_LINE) + len(_FILES_LINE):]
    return re.findall(r"`([^`]+)`", listed)


def _there(path: str) -> bool:
    """A repository path is there; a pattern for a file to add (``<name>``) has its
    folder there."""
    if "<" in path:
        path = path[:path.index("<")].rpartition("/")[0]
    return all((ROOT / one).exists() for one in _expanded(path))


def test_how_to_add_covers_the_common_changes():
    titles = how_to_add()
    assert len(titles) >= len(COMMON_CHANGES), "the section is read"
    missing = [c for c in COMMON_CHANGES if c not in titles]
    assert not missing, f"'How to add' says nothing of: {missing}"
    for title, body in titles.items():
        assert files_to_touch(body), f"{title}: no file to touch named"


def test_every_file_to_touch_is_there():
    wrong = [f"{title}: {path}" for title, body in how_to_add().items()
             for path in files_to_touch(body) if not _there(path)]
    assert not wrong, "\n".join(wrong)


def test_a_file_named_by_its_name_alone_is_one_the_change_names_in_full():
    """``record.html.j2`` in a paragraph is the ``ogacq/report/templates/record.html.j2``
    the same paragraph names: a reader is never left to guess which file."""
    wrong = []
    for title, body in how_to_add().items():
        tokens = _FILE_TOKEN.findall(body)
        full = {t.rpartition("/")[2] for t in tokens if "/" in t}
        wrong += [f"{title}: {t}" for t in tokens
                  if "/" not in t and t not in _ROOT_FILES_AND_OUTPUTS and t not in full]
    assert not wrong, "\n".join(wrong)


def test_the_how_to_add_checks_see_a_wrong_file():
    assert not _there("ogacq/report/no_such_file.py")
    assert _there("drivers/indicators/<name>.py") and not _there("nowhere/<name>.py")
    assert files_to_touch("prose `a.py`. Files to touch: `b/c.py`, `d.md`.") == ["b/c.py",
                                                                                "d.md"]
