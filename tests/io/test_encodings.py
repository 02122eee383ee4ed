"""Files as other programs save them: a UTF-8 byte order mark (a spreadsheet's "CSV
UTF-8", an editor's "UTF-8 with BOM") is accepted; another encoding is named with its
line and column and what to do."""

from __future__ import annotations

import codecs
import shutil

import numpy as np
import pytest

from ogacq.campaign.campaign_file import read_campaign
from ogacq.io.errors import InputError
from ogacq.io.loading import load_observations
from ogacq.io.machine_file import read_machine
from ogacq.io.tables import READINGS_COLUMNS, sniff
from ogacq.session.store import SessionWriter, load_session
from ogacq.sim.truth import random_truth, read_effects

BOM = codecs.BOM_UTF8


def test_a_spreadsheet_csv_with_bom_and_crlf_reads_as_the_plain_one(paper_dir, paper_machine,
                                                                    tmp_path):
    plain = paper_dir / "experiment2_12.csv"
    saved = tmp_path / "from-spreadsheet.csv"
    saved.write_bytes(BOM + plain.read_bytes().replace(b"\n", b"\r\n"))
    assert sniff(saved) == "deviations"
    ours, theirs = (load_observations(p, paper_machine) for p in (plain, saved))
    np.testing.assert_array_equal(ours.values, theirs.values)


def test_a_readings_csv_with_bom_is_recognised(tmp_path):
    saved = tmp_path / "readings.csv"
    saved.write_bytes(BOM + ",".join(READINGS_COLUMNS).encode() + b"\r\n")
    assert sniff(saved) == "readings"


def test_toml_files_with_bom(paper_dir, tmp_path):
    machine = tmp_path / "machine.toml"
    machine.write_bytes(BOM + (paper_dir / "machine.toml").read_bytes())
    assert read_machine(machine) == read_machine(paper_dir / "machine.toml")
    effects = tmp_path / "effects.toml"
    effects.write_bytes(BOM + b"[squareness]\nxy = 0.5\n")
    assert read_effects(effects, random_truth(0)).hidden()["squareness.xy"] == 0.5
    campaign = tmp_path / "campaign.toml"
    campaign.write_bytes(BOM + b'machine = "machine.toml"\n[simulator]\nseed = 2\n')
    assert read_campaign(campaign).simulator.seed == 2


def test_a_latin1_comment_in_a_machine_file_is_named_with_its_line(paper_dir, tmp_path):
    machine = tmp_path / "machine.toml"
    lines = (paper_dir / "machine.toml").read_bytes().splitlines(keepends=True)
    machine.write_bytes(b"".join(lines[:2]) + "# mesur\xe9 au pied\n".encode("latin-1")
                        + b"".join(lines[2:]))
    with pytest.raises(InputError) as caught:
        read_machine(machine)
    assert str(caught.value) == (f"{machine}:3: not UTF-8 text (byte 0xe9 at column 8); "
                                 "save the file as UTF-8")


def test_a_latin1_byte_in_a_csv_is_named_with_its_line(paper_dir, paper_machine, tmp_path):
    saved = tmp_path / "deviations.csv"
    lines = (paper_dir / "experiment2_12.csv").read_bytes().splitlines(keepends=True)
    saved.write_bytes(lines[0] + lines[1] + "d\xe9,0.1\n".encode("latin-1") + b"".join(lines[2:]))
    with pytest.raises(InputError, match=r"deviations\.csv:3: not UTF-8 text \(byte 0xe9 at "
                                         r"column 2\)"):
        load_observations(saved, paper_machine)


def test_a_session_saved_with_bom_loads(tmp_path):
    session = tmp_path / "s.jsonl"
    SessionWriter.create(session, {"machine": {}, "plan": None}).close()
    shutil.copy(session, tmp_path / "plain.jsonl")
    session.write_bytes(BOM + session.read_bytes())
    assert sniff(session) == "session"
    assert load_session(session).header == load_session(tmp_path / "plain.jsonl").header
