"""Options of plain types are coerced without pydantic (ogacq.cli.coercion), to the
same values typer's own pydantic coercion gives for every value both accept, and
stricter where Python's number syntax is looser than a user means (fullwidth digits,
underscores, infinities)."""

from __future__ import annotations

import json
import subprocess
import sys
from enum import StrEnum
from pathlib import Path

import pytest
from typer._click import Context
from typer._click.exceptions import BadParameter
from typer._coercion import build_runtime_param, resolve_type_descriptor
from typer.core import TyperCommand
from typer.models import OptionInfo

from ogacq.cli.coercion import plain_runtime_param

PROBE = """
import json, sys
from ogacq.cli.app import main
main(sys.argv[1:])
print(json.dumps(sorted(sys.modules)))
"""


class Colour(StrEnum):
    red = "red"
    blue = "blue"


CASES = [
    (int, OptionInfo(), ["3", "-2", "+7", "0012"], ["x", "3.5", "", "1_000", "１２", "1e3"]),
    (float, OptionInfo(), ["3", "-2.5", ".5", "1e-3", "+4.", "2E+2"],
     ["abc", "1_0.0", "１.5", "inf", "nan", "1e400", "0x10"]),
    (int, OptionInfo(min=1, max=10), ["1", "10"], ["0", "11"]),
    (float, OptionInfo(min=-40.0, max=80.0), ["-40", "80.0"], ["-40.5", "80.01"]),
    (str, OptionInfo(), ["anything", ""], []),
    (Path, OptionInfo(), ["a/b.csv", "/tmp"], []),
    (Colour, OptionInfo(), ["red", "blue"], ["green", "RED"]),
    (int | None, OptionInfo(), ["5"], ["five"]),
    (list[str], OptionInfo(), [["a", "b"]], []),
]


def coerce(runtime, value):
    return runtime._coerce_value(value, param=None, ctx=Context(TyperCommand("probe")))


@pytest.mark.parametrize("annotation, info, good, bad", CASES,
                         ids=[repr(c[0]) + repr(c[1].min) for c in CASES])
def test_same_values_as_typer_and_refusals(annotation, info, good, bad):
    descriptor = resolve_type_descriptor(annotation, info)
    ours, typers = plain_runtime_param(descriptor), build_runtime_param(descriptor)
    assert ours is not None
    for value in good:
        assert coerce(ours, value) == coerce(typers, value), value
    for value in bad:
        with pytest.raises(BadParameter):
            coerce(ours, value)


def test_a_file_annotation_is_left_to_typer():
    from typing import TextIO

    assert plain_runtime_param(resolve_type_descriptor(TextIO, OptionInfo())) is None


def test_a_refit_does_not_import_pydantic_nor_rich_under_json():
    paper = Path(__file__).resolve().parents[2] / "ogacq" / "examples" / "paper"
    run = subprocess.run([sys.executable, "-c", PROBE, "refit", str(paper / "experiment2_12.csv"),
                          "-m", str(paper / "machine.toml"), "--json"],
                         capture_output=True, text=True, timeout=60)
    assert run.returncode == 0, run.stderr
    loaded = json.loads(run.stdout.splitlines()[-1])
    assert "numpy" in loaded  # the probe sees the command's imports
    assert not [m for m in loaded if m.split(".")[0] in ("pydantic", "pydantic_core", "rich")]
