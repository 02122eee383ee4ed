"""Register-map profiles: the shipped ones load, broken ones fail naming file and key."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from ogacq_drivers.axes.profile import (
    ProfileError,
    available_profiles,
    load_profile,
    profiles_folder,
)


def test_shipped_profiles_load() -> None:
    assert {"iai-pcon", "cia402"} <= set(available_profiles())
    iai = load_profile("iai-pcon")
    cia = load_profile("cia402")
    assert iai.transport.default == "rtu" and cia.transport.default == "tcp"
    assert iai.codec.word_order == "high_first" and cia.codec.word_order == "low_first"
    assert iai.device_ids == {"x": 1, "y": 2, "z": 3} == cia.device_ids
    assert iai.offset.kind == "software"
    assert cia.offset.kind == "home_offset" and cia.value(cia.offset.value).address == 0x607C
    assert cia.nvm.kind == "store_parameters" and cia.value(cia.nvm.value).address == 0x1010
    assert iai.value("move_target").address == 0x9900
    assert iai.flags["moving"].value == "expansion_status" and iai.flags["moving"].bit == 5
    assert cia.flags["in_position"].bit == 10 and cia.flags["moving"].invert
    jec, kinco = load_profile("mr-je-c"), load_profile("kinco-fd")
    assert jec.transport.functions == (3, 8, 16) and not jec.transport.single_register_write
    assert jec.device_ids == {"x": 255, "y": 255, "z": 255} and jec.nvm.kind == "none"
    assert kinco.value("controlword").address == 0x3100
    assert kinco.value("statusword").address == 0x3200 and kinco.offset.kind == "software"


def test_load_by_path_gives_same_profile() -> None:
    by_name = load_profile("cia402")
    by_path = load_profile(profiles_folder() / "cia402.toml")
    assert by_name.values == by_path.values and by_name.commands == by_path.commands


def _broken(tmp_path: Path, old: str, new: str, base: str = "iai-pcon") -> Path:
    text = (profiles_folder() / f"{base}.toml").read_text()
    assert old in text, f"test set-up: {old!r} not in {base}.toml"
    path = tmp_path / "broken.toml"
    path.write_text(text.replace(old, new, 1))
    return path


@pytest.mark.parametrize(
    ("old", "new", "key", "message"),
    [
        ("counts_per_mm = 100.0 ", "", "codec", "missing key 'counts_per_mm'"),
        ("[codec]\n", "[codec]\nwords_order = 1\n", "codec", "unknown key 'words_order'"),
        ('word_order = "high_first"', 'word_order = "big"', "codec.word_order", "must be one of"),
        (
            "address = 0x9000,",
            "address = true,",
            "values.position_actual.address",
            "must be a whole number",
        ),
        ('"device_status_1", bit = 12 }', '"device_status_1", bit = 16 }', "flags.servo_on.bit",
         "must be 0..15"),
        (
            'value = "expansion_status", bit = 5',
            'value = "status_ext", bit = 5',
            "flags.moving.value",
            "no value named 'status_ext'",
        ),
        (
            '  { op = "wait", flag = "alarm", state = false },\n',
            "",
            "commands.alarm_reset.start[1]",
            "followed by a wait or confirm",
        ),
        (
            '"move_band", "move_speed"',
            '"move_speed", "move_band"',
            "commands.move.start[0].to",
            "not contiguous",
        ),
        ('"$band_mm"', '"$band"', "commands.move.start[0].value[1]", "is not one of"),
        (
            'to = "servo_on_command", value = true',
            'to = "position_actual", value = 1.0',
            "commands.enable.start[3].to",
            "not writable",
        ),
        (
            "address = 0x9002,",
            "address = 0x9001,",
            "values.alarm_code.address",
            "already belongs to 'position_actual'",
        ),
        ('kind = "software"', 'kind = "register"', "offset.kind", "must be one of"),
        (
            'to = "home_command", value = false },',
            'to = "home_command", value = false, skip_unchanged = true, edge = true },',
            "commands.home.start[0]",
            "edge and skip_unchanged exclude each other",
        ),
        (  # the move's start is confirmed in finish: without it, refused
            '  { op = "confirm", any = ["moving"], done = "in_position", at = "$target_mm" },'
            "\n]\n\n[commands.stop]",
            "]\n\n[commands.stop]",
            "commands.move.start[0]",
            "followed by a wait or confirm",
        ),
        ("[limits]", "[limits]\n", "", ""),  # control: harmless edit still loads
    ],
)
def test_bad_profile_names_file_and_key(
    tmp_path: Path, old: str, new: str, key: str, message: str
) -> None:
    path = _broken(tmp_path, old, new)
    if not key:
        load_profile(path)
        return
    with pytest.raises(ProfileError) as caught:
        load_profile(path)
    text = str(caught.value)
    assert str(path) in text
    assert f"[{key}]" in text
    assert message in text
    assert caught.value.key == key


@pytest.mark.parametrize(("old", "new", "key", "message"), [
    ('ambient = "ambient_temperature"', 'ambient = "room"', "temperature.ambient",
     "no value named 'room'"),
    ('ambient = "ambient_temperature"', 'ambient = "position_actual"', "temperature.ambient",
     "must be a raw holding register"),
    ('degc_per_count = 0.1 ', 'degc_per_count = 0 ', "temperature.degc_per_count",
     "must be positive"),
])
def test_bad_temperature_register_names_its_key(tmp_path: Path, old: str, new: str, key: str,
                                                 message: str) -> None:
    with pytest.raises(ProfileError) as caught:
        load_profile(_broken(tmp_path, old, new, base="cia402"))
    assert caught.value.key == key and message in str(caught.value)
    # the shipped one: both registers, 0.1 degC a count, on the x drive
    spec = load_profile("cia402").temperature
    assert (spec.ambient, spec.machine, spec.degc_per_count, spec.axis) == (
        "ambient_temperature", "machine_temperature", 0.1, "x")


def test_missing_top_level_table(tmp_path: Path) -> None:
    text = (profiles_folder() / "cia402.toml").read_text()
    path = tmp_path / "no_sim.toml"
    path.write_text(re.sub(r"\[sim\][^\[]*", "", text))
    with pytest.raises(ProfileError, match=r"no_sim\.toml: \[\] missing key\(s\) 'sim'|missing"):
        load_profile(path)


def test_invalid_toml_and_unknown_name(tmp_path: Path) -> None:
    path = tmp_path / "garbage.toml"
    path.write_text("name = \n")
    with pytest.raises(ProfileError, match="garbage.toml: not valid TOML"):
        load_profile(path)
    with pytest.raises(ProfileError, match="no such profile; available: cia402, iai-pcon"):
        load_profile("no-such-controller")


@pytest.mark.parametrize("name", available_profiles())  # a new file is checked as it lands
def test_every_register_coil_and_bit_cites_its_source(name: str) -> None:
    """Each line of [values] and [flags] names its manual ([TAG] defined in the header)
    or says "no source"; a register map without sources cannot be checked."""
    text = (profiles_folder() / f"{name}.toml").read_text()
    tags = set(re.findall(r"^#\s+(\[[A-Za-z0-9]+\])\s", text, flags=re.M))
    assert tags, f"{name}: the header defines no source"
    section = ""
    for line in text.splitlines():
        if line.startswith("["):
            section = line.split("]")[0] + "]"
            continue
        if section in ("[values]", "[flags]") and re.match(r"^\w+\s*=\s*\{", line):
            comment = line.partition("#")[2]
            cited = {t + "]" for t in re.findall(r"\[[A-Za-z0-9]+", comment)}
            assert "no source" in comment or cited & tags, f"{name}: {line}"


def test_the_campaign_file_docs_name_every_shipped_profile() -> None:
    """docs/formats.md lists the `[controller] profile` choices by hand, as a reader
    wants them: the list is the profile files', no more, no less."""
    docs = (Path(__file__).resolve().parents[2] / "docs" / "formats.md").read_text()
    row = next(line for line in docs.splitlines() if line.startswith("| `[controller]`"))
    listed = re.search(r"`profile` \(([^)]*?), or a profile file\)", row)
    assert listed is not None, row
    assert sorted(listed.group(1).split(", ")) == available_profiles()


def test_the_readme_names_every_shipped_profile() -> None:
    readme = (Path(__file__).resolve().parents[2] / "README.md").read_text()
    listed = re.search(r"`ogacq sim \[--profile ([^\]]+)\]", readme)
    assert listed is not None
    assert sorted(listed.group(1).split("\\|")) == available_profiles()
