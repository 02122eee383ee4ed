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


def test_a_utf16_file_is_named_as_such(tmp_path):
    """A spreadsheet's "Unicode text" is UTF-16: said so, not as a wrong byte."""
    saved = tmp_path / "readings.csv"
    saved.write_bytes(",".join(READINGS_COLUMNS).encode("utf-16") + b"\n\x00")
    with pytest.raises(InputError) as caught:
        sniff(saved)
    assert str(caught.value) == (f"{saved}:1: UTF-16 text (it begins with the byte order mark "
                                 "FF FE: a spreadsheet's \"Unicode text\"?); save the file "
                                 "as UTF-8")


@pytest.mark.parametrize(("content", "line"), [
    (b"name,value_mm\rdx_y+,0.1\r", 1),  # every line (classic Mac OS)
    (b"name,value_mm\r\ndx_y+,0.1\rdy_x+,0.2\r\n", 2)])
def test_a_lone_carriage_return_is_refused_with_its_line(paper_machine, tmp_path, content,
                                                         line):
    """The formats' lines end in LF or CRLF (docs/formats.md, "Text"); a file whose
    lines end in a lone CR crashed the sniffer's CSV reader (a traceback)."""
    saved = tmp_path / "deviations.csv"
    saved.write_bytes(content)
    with pytest.raises(InputError) as caught:
        load_observations(saved, paper_machine)
    assert str(caught.value) == (f"{saved}:{line}: a line ends in a lone carriage return (CR, the "
                                 "line end of classic Mac OS): lines end in LF or CRLF; save the "
                                 "file with Unix or Windows line ends")


def test_a_decimal_comma_in_toml_says_what_to_write(paper_dir, tmp_path):
    machine = tmp_path / "machine.toml"
    machine.write_text((paper_dir / "machine.toml").read_text().replace("310.25", "310,25"))
    with pytest.raises(InputError) as caught:
        read_machine(machine)
    line = machine.read_text().splitlines().index("leg_length_mm = 310,25") + 1
    assert str(caught.value) == (f"{machine}:{line}: leg_length_mm = 310,25: a decimal comma; "
                                 "TOML writes a number's decimals after a point: "
                                 "leg_length_mm = 310.25")


def test_a_session_line_in_another_encoding_names_its_byte(tmp_path):
    """A session is written in UTF-8; a line an editor saved in cp1252 is corrupt, and
    the message says why rather than only "not valid JSON"."""
    session = tmp_path / "s.jsonl"
    SessionWriter.create(session, {"machine": {"name": "Juergen"}, "plan": None}).close()
    data = session.read_bytes()
    session.write_bytes(data.replace(b"Juergen", "Jürgen".encode("cp1252")))
    column = data.index(b"Juergen") + 2
    with pytest.raises(InputError) as caught:
        load_session(session)
    assert str(caught.value) == (f"{session}:1: not an ogacq session (line 1 is not valid JSON: "
                                 f"not UTF-8 text (byte 0xfc at column {column})); give the "
                                 "session.jsonl a campaign wrote")


def test_a_lone_carriage_return_in_toml_is_named_not_expected_newline(paper_dir, tmp_path):
    machine = tmp_path / "machine.toml"
    machine.write_bytes((paper_dir / "machine.toml").read_bytes().replace(b"\n", b"\r"))
    with pytest.raises(InputError) as caught:
        read_machine(machine)
    assert str(caught.value) == (f"{machine}:1: a line ends in a lone carriage return (CR, the "
                                 "line end of classic Mac OS): lines end in LF or CRLF; save the "
                                 "file with Unix or Windows line ends")
