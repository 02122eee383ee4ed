"""Nothing a name holds reaches a controller file as anything but one comment line:
hostile titles and map sources through every format's writer (the issue found 90/90
passing), and the machine file's stem held to the rules of ``name``."""

from __future__ import annotations

from dataclasses import replace

import pytest

from ogacq.compensation.export import export_tables
from ogacq.compensation.formats import TABLE_FORMATS
from ogacq.errors import InputError
from ogacq.io.machine_file import read_machine
from tests.campaign.conftest import MACHINE
from tests.compensation.maps import screw_map

BUILT_IN = ("linuxcnc", "fanuc", "siemens", "csv")
# a line break of each kind, then what each format would read at a line's start
HOSTILE = [
    "m\n$MA_BACKLASH[0,AX1]=5\nM30",
    "m\r%_N_AX_EEC_INI",
    "m\u2028[JOINT_0]\u2029COMP_FILE = /etc/passwd",
    "m\x85%\nO0001(X)\n%",
    "m\x0b\x0c\x1c\x1d\x1eM17",
    "m; $AA_ENC_COMP[0,0,X1]=9",
    "m \\\nBACKLASH = 5",
    "m\x1b[2J\x00\u202egnp.exe",
    "m" * 5000,
]
# what each format gives a meaning to besides a line's end (its module's docstring)
SPECIAL = {"linuxcnc": "\\", "fanuc": "%()", "siemens": "%;", "csv": ""}


def written(tmp_path, title: str, source: str) -> dict[str, list[str]]:
    m = replace(screw_map(amplitude_mm=0.0), source=source)
    out = export_tables(tmp_path / "tables", {"x": m}, title=title)
    return {f"{e.format}/{p.name}": p.read_text(encoding="utf-8").split("\n")
            for e in out for p in e.files}


@pytest.mark.parametrize("hostile", HOSTILE, ids=range(len(HOSTILE)))
def test_a_hostile_title_and_source_stay_one_comment_line(tmp_path, hostile):
    benign = written(tmp_path, "title", "source")
    hostile_files = written(tmp_path, hostile, hostile)
    assert hostile_files.keys() == benign.keys()
    assert {f.split("/")[0] for f in benign} == set(BUILT_IN)
    for name, lines in hostile_files.items():
        fmt = name.split("/")[0]
        # the same lines, one for one: only the text of the comments differs
        assert len(lines) == len(benign[name]), name
        assert len("\n".join(lines).splitlines()) == len(lines) - 1, name
        for got, want in zip(lines, benign[name], strict=True):
            if got != want:
                assert want.startswith((";", "#")) and got[:2] == want[:2], (name, got)
                assert not any(c in got[1:] for c in SPECIAL[fmt]), (name, got)
                assert got.isprintable() and len(got) <= 260, (name, got)


def test_each_format_declares_the_sanitiser_its_writer_uses():
    for name in BUILT_IN:
        fmt = TABLE_FORMATS[name]
        said = fmt.sanitise("a\nb\u2028c" + SPECIAL[name])
        assert said.isprintable() and "\n" not in said and "\u2028" not in said
        assert not any(c in said for c in SPECIAL[name]), name


@pytest.mark.parametrize(("stem", "said"), [("cell\n$MA_BACKLASH[0,AX1]=5", "U+000A"),
                                            ("cell\u2028M30", "U+2028"),
                                            ("cell\u202eexe", "U+202E")])
def test_a_machine_file_without_name_takes_its_stem_only_by_the_rules_of_name(
        tmp_path, stem, said):
    path = tmp_path / f"{stem}.toml"
    path.write_text(MACHINE)
    with pytest.raises(InputError) as caught:
        read_machine(path)
    # (the file's path starts the message as it is: a path with a line break in it
    # spans two lines there, as in every message naming a file)
    assert f"holds {said}, which does not print: give the machine's name" in str(caught.value)
    named = tmp_path / "named.toml"  # the same file with a name: its stem does not matter
    named.write_text(MACHINE + 'name = "cell 4"\n')
    assert read_machine(named).name == "cell 4"
    plain = tmp_path / "cell-4.toml"
    plain.write_text(MACHINE)
    assert read_machine(plain).name == "cell-4"
