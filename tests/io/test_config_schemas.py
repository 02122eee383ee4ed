"""The declared schemas: each file kind writes what it reads back, and refuses a
bad value at load, naming the file, the key and the line."""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import pytest

from ogacq_drivers.config_schema import (
    Field,
    MapOf,
    Source,
    Table,
    Variants,
    dump,
    load,
    number,
    text,
)
from ogacq.campaign.campaign_file import (
    AxisEndpoint,
    Campaign,
    ControllerSpec,
    GaugeSpec,
    SimulatorSpec,
    campaign_text,
    read_campaign,
)
from ogacq.io.errors import InputError
from ogacq.io.machine_file import read_machine, write_machine
from ogacq.model.machine import PAPER_PROTOTYPE, PAPER_PROTOTYPE_DIGITAL
from ogacq.model.parameters import PARAM_INDEX
from ogacq.protocol.plan import ProtocolConfig, StabilityRule
from ogacq.sim.truth import random_truth, read_effects
from ogacq.writeback.table import read_offset_table
from tests.campaign.conftest import MACHINE


def _issue_error(issue):
    return ValueError(f"{issue.line}|{issue.key}|{issue.message}")


def test_machine_round_trip(tmp_path: Path) -> None:
    for machine in (PAPER_PROTOTYPE, PAPER_PROTOTYPE_DIGITAL,
                    replace(PAPER_PROTOTYPE, gauge_repeatability_mm=0.0007)):
        again = read_machine(write_machine(tmp_path / "m.toml", machine, "a comment"))
        assert replace(again, name=machine.name) == machine


def test_the_paper_fixture_is_the_paper_prototype(paper_dir: Path) -> None:
    """The fixture file states the one definition (ogacq.model.machine), not another."""
    fixture = read_machine(paper_dir / "machine.toml")
    assert replace(fixture, name=PAPER_PROTOTYPE.name) == PAPER_PROTOTYPE


def _campaign(tmp_path: Path, **parts) -> Campaign:
    write_machine(tmp_path / "machine.toml", PAPER_PROTOTYPE, "")
    protocol = ProtocolConfig(postures=("zero", 30.0, 55.0, -90.0), cycles=2,
                              approach="both", settle_s=0.25,
                              stability=StabilityRule(readings=4, timeout_s=3.0))
    return Campaign(tmp_path / "campaign.toml", PAPER_PROTOTYPE, tmp_path / "machine.toml",
                    tmp_path / "runs" / "s.jsonl", protocol, **parts)


@pytest.mark.parametrize("parts", [
    {"simulator": SimulatorSpec(seed=4, speed=30.0, profile="iai-pcon", noise_mm=0.002,
                                gauge_layout="moved", gauge_protocol="uwave",
                                gauge_protocols=(("x_y", "usb-itn"), ("z_y", "sylvac")))},
    {"controller": ControllerSpec("mr-je-c", timeout_s=0.5, axes={
        a: AxisEndpoint(f"10.0.0.1{k}:502", 255) for k, a in enumerate("xyz")}),
     "gauges": [GaugeSpec(g, "mitutoyo-01a", "/dev/ttyUSB0", str(k), serial=f"SN {k}",
                          baudrate=9600)
                for k, g in enumerate(("y_x", "z_x", "x_y", "z_y", "x_z", "y_z"), 1)]},
    {"controller": ControllerSpec("iai-pcon", "/dev/ttyUSB9", baudrate=38400),
     "gauges": [GaugeSpec(g, "digimatic", f"/dev/ttyUSB{k}", unit="inch")
                for k, g in enumerate(("y_x", "z_x", "x_y", "z_y", "x_z", "y_z"))]},
], ids=["simulator", "per-axis", "serial"])
def test_campaign_round_trip(tmp_path: Path, parts: dict) -> None:
    campaign = _campaign(tmp_path, **parts)
    campaign.path.write_text(campaign_text(campaign, comment="test",
                                           notes={"protocol": "a note"}))
    again = read_campaign(campaign.path)
    assert again.protocol == campaign.protocol
    assert again.controller == campaign.controller and again.gauges == campaign.gauges
    assert again.simulator == campaign.simulator
    assert again.session == campaign.session and again.machine_path == campaign.machine_path
    assert "# a note\n[protocol]" in campaign.path.read_text()


def test_offset_table_written_value_round_trips_and_nan_is_refused(tmp_path: Path) -> None:
    from ogacq.writeback.table import write_offset_table

    values = {"x": 1 / 3, "y": -2.5e-9, "z": 0.0}
    assert write_offset_table(tmp_path / "o.toml", values, session="s").offsets_mm == values
    with pytest.raises(ValueError, match="joint_offset_mm.z = nan: not a finite number"):
        write_offset_table(tmp_path / "o.toml", {**values, "z": math.nan})


@pytest.mark.parametrize(("text_", "line", "words"), [
    ("[squareness]\nxy = 0.5\nxw = 1\n", 3, "[squareness]: entry 'xw' is not one of xy, xz, yz"),
    ("[joint_offset]\nx = nan\n", 2, "joint_offset.x must be a finite number, got nan"),
    ("[gauges]\nnoise_mm = -1\n", 2, "gauges.noise_mm must be 0..1, got -1"),
    ("[lead_screw.x]\namplitude_mm = 0.01\npitch_mm = 0\n", 3,
     "lead_screw.x.pitch_mm must be 0.1..1000, got 0"),
    ("[lead_screw.x]\namplitude_mm = 0.01\n", 1, "[lead_screw.x] needs 'pitch_mm'"),
    ("[wobble]\nx = 1\n", 1, "unknown effect 'wobble' in the effects file"),
])
def test_bad_effects_file_refused_with_line(tmp_path: Path, text_: str, line: int,
                                            words: str) -> None:
    path = tmp_path / "effects.toml"
    path.write_text(text_)
    with pytest.raises(InputError) as bad:
        read_effects(path, random_truth(1))
    assert f"{path}:{line}:" in str(bad.value) and words in str(bad.value)


def test_effects_file_applied_on_the_base(tmp_path: Path) -> None:
    path = tmp_path / "effects.toml"
    path.write_text("[squareness]\nxy = 0.5\n[gauges]\nnoise_mm = 0.002\n"
                    "[lead_screw.y]\namplitude_mm = 0.01\npitch_mm = 10\n")
    base = random_truth(1)
    truth = read_effects(path, base)
    assert truth.theta[PARAM_INDEX["squareness.xy"]] == 0.5 and truth.noise_mm == 0.002
    assert truth.theta[PARAM_INDEX["joint_offset.x"]] == base.theta[PARAM_INDEX["joint_offset.x"]]
    assert truth.lead_screw[1].pitch_mm == 10.0


@pytest.mark.parametrize(("table", "words"), [
    ("[protocol]\nmove_timeout_s = 0\n", "protocol.move_timeout_s must be 0.001..3600, got 0"),
    ("[protocol]\npostures = [\"zero\", true]\n",
     "protocol.postures[1] must be text or a number, got True"),
    ("[stability]\nreadings = 2.5\n", "stability.readings must be a whole number, got 2.5"),
    ("[simulator]\nseed = -5\n", "simulator.seed must be at least 0, got -5"),
    ("[simulator]\nnoise_mm = inf\n", "simulator.noise_mm must be a finite number, got inf"),
    ("[simulator]\neffects = 3\n", "simulator.effects must be text, got 3"),
    ("[simulator]\nsped = 3\n", "unknown key 'sped' in [simulator]; did you mean speed?"),
])
def test_campaign_values_refused_at_load_with_line(tmp_path: Path, table: str,
                                                   words: str) -> None:
    (tmp_path / "machine.toml").write_text(MACHINE)
    path = tmp_path / "campaign.toml"
    path.write_text('machine = "machine.toml"\n' + table)
    with pytest.raises(InputError) as bad:
        read_campaign(path)
    assert f"{path}:3: {words}" in str(bad.value)


def test_offset_table_format_and_axis_names_are_checked(tmp_path: Path) -> None:
    path = tmp_path / "o.toml"
    path.write_text('format = "ogacq-offsets/2"\n[joint_offset_mm]\nx = 0\ny = 0\nz = 0\n')
    with pytest.raises(InputError, match=r"o.toml:1: format must be one of ogacq-offsets/1"):
        read_offset_table(path)


# ---- the engine itself, on a small schema

_STEP = Variants("op", {
    "wait": Table((Field("op", text("wait"), required=True),
                   Field("seconds", number(positive=True), required=True))),
    "say": Table((Field("op", text("say"), required=True), Field("words", text()))),
})
_SCHEMA = Table((
    Field("name", text(), required=True),
    Field("steps", MapOf(_STEP, noun="step")),
))


def test_engine_names_nested_keys_and_their_lines() -> None:
    body = 'name = "n"\n[steps]\nfirst = { op = "wait", seconds = -1 }\nsecond = { op = "x" }\n'
    with pytest.raises(ValueError, match=r"^3\|steps.first.seconds\|steps.first.seconds must be "
                                         r"positive, got -1$"):
        load(_SCHEMA, __import__("tomllib").loads(body), Source("f", _issue_error, body))
    body = body.replace("seconds = -1", "seconds = 2")
    with pytest.raises(ValueError, match=r"^4\|steps.second.op\|.*must be one of wait, say"):
        load(_SCHEMA, __import__("tomllib").loads(body), Source("f", _issue_error, body))


def test_engine_writes_what_it_reads() -> None:
    value = {"name": 'quote " and \\ back', "steps": {
        "a": {"op": "wait", "seconds": 0.1}, "b b": {"op": "say", "words": "é"}}}
    written = dump(_SCHEMA, value)
    import tomllib

    assert load(_SCHEMA, tomllib.loads(written), Source("f", _issue_error, written)) == value


@pytest.mark.parametrize(("text_", "words"), [
    ('format = "ogacq-offsets/1"\n[joint_o', "Expected ']' at the end of a table declaration"),
    ('format = "ogacq-offsets/1"\n[joint_offset_mm]\nx = "1.2', "Unterminated string"),
])
def test_a_toml_file_cut_short_names_its_last_line(tmp_path: Path, text_: str,
                                                   words: str) -> None:
    """tomllib names no line for a problem "at end of document": a file cut short (a
    copy interrupted, a disk full) is named by its last line and said to end there."""
    path = tmp_path / "offsets.toml"
    path.write_text(text_)
    with pytest.raises(InputError) as caught:
        read_offset_table(path)
    assert str(caught.value) == (f"{path}:{len(text_.splitlines())}: not valid TOML: {words} "
                                 "(the file ends there: cut short?)")
