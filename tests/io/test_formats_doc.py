"""docs/formats.md shows files that load: its TOML examples go through the readers."""

from __future__ import annotations

import re
from pathlib import Path

from ogacq.cli.app import main
from ogacq.io.machine_file import read_machine
from ogacq.sim.truth import random_truth, read_effects
from ogacq.writeback.table import read_offset_table

DOC = Path(__file__).resolve().parents[2] / "docs" / "formats.md"


def test_the_documented_toml_examples_load(tmp_path):
    machine, effects, offsets = re.findall(r"```toml\n(.*?)```", DOC.read_text(), re.S)
    for name, text in (("machine", machine), ("effects", effects), ("offsets", offsets)):
        (tmp_path / f"{name}.toml").write_text(text)
    assert read_machine(tmp_path / "machine.toml").leg_length_mm == 310.25
    hidden = read_effects(tmp_path / "effects.toml", random_truth(0)).hidden()
    assert hidden["squareness.xy"] == 0.5 and hidden["gauge_scale.z_y"] == 300
    assert read_offset_table(tmp_path / "offsets.toml").offsets_mm["z"] == -0.9035


def test_the_help_points_to_the_formats_and_init(capsys):
    assert main(["--help"]) == 0
    out = " ".join(capsys.readouterr().out.split())
    assert "docs/formats.md" in out and "ogacq init machine|campaign" in out
    assert DOC.is_file()
