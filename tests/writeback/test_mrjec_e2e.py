"""A campaign, `offsets write` and `offsets restore` end to end against an MR-JE-C-style
drive: ``ogacq sim --profile mr-je-c`` serves one Modbus TCP endpoint per axis, unit 255
on each, and answers anything but FC 03/08/16 with "illegal function". Then the same
drives with a profile whose home-offset sign is wrong: the pre-flight check stops the
campaign and the restore before anything moves further or is written, naming the field."""

from __future__ import annotations

from pathlib import Path

import pytest

from ogacq_drivers.axes.preflight import PreflightError
from ogacq_drivers.axes.profile import load_profile
from ogacq.campaign.campaign_file import read_campaign
from ogacq.campaign.run import run_campaign
from ogacq.model.parameters import AXES
from ogacq.session.records import OffsetsRecord, ReadingRecord
from ogacq.session.store import load_session
from tests.writeback.conftest import FAST_STABILITY, SETTLE_S, controller_offsets, simulator
from tests.writeback.conftest import ogacq_here as ogacq


def _campaign(folder: Path, info: dict, name: str, profile: str) -> Path:
    axes = "".join(
        f'{axis} = {{ port = "{a["host"]}:{a["port"]}", device_id = {a["device_ids"][axis]} }}\n'
        for axis, a in info["modbus_axes"].items())
    gauges = "".join(f'\n[[gauges]]\ngauge = "{key}"\nprotocol = "{g["protocol"]}"\n'
                     f'port = "{g["port"]}"\n' for key, g in info["gauges"].items())
    path = folder / f"{name}.toml"
    path.write_text(f'machine = "machine.toml"\nsession = "{name}.jsonl"\n\n[controller]\n'
                    f'profile = "{profile}"\n[controller.axes]\n{axes}\n[protocol]\n'
                    f'postures = ["zero", "max", "zero"]\ncycles = 1\nsettle_s = {SETTLE_S}\n'
                    f"{FAST_STABILITY}{gauges}")
    return path


def test_mrjec_campaign_write_restore_and_a_wrong_sign_caught(tmp_path, capsys, monkeypatch):
    zeros = dict.fromkeys(AXES, 0.0)
    wrong_sign = tmp_path / "mr-je-c-wrong-sign.toml"
    wrong_sign.write_text(Path(load_profile("mr-je-c").source).read_text()
                          .replace("sign = -1 ", "sign = 1 "))
    with simulator(tmp_path, "mr-je-c", 5) as info:
        ports = {a["port"] for a in info["modbus_axes"].values()}
        assert len(ports) == 3 and {a["device_ids"][x] for x, a in
                                    info["modbus_axes"].items()} == {255}
        first = _campaign(tmp_path, info, "first", "mr-je-c")
        outcome = run_campaign(read_campaign(first))
        session = load_session(outcome.session_path)
        controller = session.header.station["controller"]
        assert controller["axes"]["y"]["device_id"] == 255
        assert controller["axes"]["y"]["port"].endswith(str(info["modbus_axes"]["y"]["port"]))
        assert len(session.of_type(ReadingRecord)) == 18  # 3 legs x 2 gauges x 3 postures

        written = ogacq(capsys, monkeypatch, "offsets", "write", session.path, "--yes",
                        "--force")
        assert written.returncode == 0, written.stdout + written.stderr
        done = [r for r in load_session(session.path).of_type(OffsetsRecord)
                if r.stage == "done"][-1]
        held = controller_offsets(first)
        assert held == pytest.approx(done.details["new_mm"], abs=1e-9) and held != zeros
        assert done.details["rehomed"]

        # the same drives, a profile with the wrong home-offset sign: stopped after the
        # homing, before the probe move, naming the field; no reading recorded
        wrong = _campaign(tmp_path, info, "wrong", str(wrong_sign))
        with pytest.raises(PreflightError) as stopped:
            run_campaign(read_campaign(wrong))
        assert "change offset.sign to -1" in str(stopped.value)
        assert stopped.value.field == "offset.sign"
        assert not (tmp_path / "wrong.jsonl").exists() or \
            not load_session(tmp_path / "wrong.jsonl").of_type(ReadingRecord)

        # and a profile with the wrong 32-bit word order: stopped, the field named
        swapped = tmp_path / "mr-je-c-swapped.toml"
        swapped.write_text(Path(load_profile("mr-je-c").source).read_text()
                           .replace('word_order = "low_first"', 'word_order = "high_first"'))
        with pytest.raises(PreflightError) as stopped:
            run_campaign(read_campaign(_campaign(tmp_path, info, "swapped", str(swapped))))
        assert stopped.value.field == "codec.word_order" and "codec.word_order" in \
            str(stopped.value)
        assert controller_offsets(first) == pytest.approx(held, abs=1e-9)  # nothing written

        # restore through the wrong profile: refused by the pre-flight, nothing written
        wrong_restore = first.with_name("first-wrong.toml")
        wrong_restore.write_text(first.read_text().replace('profile = "mr-je-c"',
                                                           f'profile = "{wrong_sign}"'))
        records = len(load_session(session.path).of_type(OffsetsRecord))
        # (the policy sees the offsets "changed" through the wrong sign: --force past it)
        refused = ogacq(capsys, monkeypatch, "offsets", "restore", session.path, "--yes",
                        "--force", "--campaign", wrong_restore)
        assert refused.returncode == 3, refused.stdout + refused.stderr
        assert "offset.sign" in refused.stderr and "nothing written" in refused.stderr
        assert controller_offsets(first) == pytest.approx(held, abs=1e-9)
        after = load_session(session.path).of_type(OffsetsRecord)[records:]
        assert [r.stage for r in after] == ["refused"]

        restored = ogacq(capsys, monkeypatch, "offsets", "restore", session.path, "--yes")
        assert restored.returncode == 0, restored.stdout + restored.stderr
        assert controller_offsets(first) == zeros
