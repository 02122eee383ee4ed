"""``ogacq report --pdf``: the page printed by a headless Chromium (one start for this
module, the command's own), and a clear exit 3 when there is no browser."""

from __future__ import annotations

import json

import pytest

from ogacq.cli.app import main
from ogacq.report.printing import BROWSER_ENV
from tests.cli.helpers import run_ogacq
from tests.record.browser import need_chromium, page_text


def test_report_pdf_prints_the_record(campaign_sessions, tmp_path):
    from pypdf import PdfReader

    need_chromium()
    out = tmp_path / "out"
    proc = run_ogacq("report", campaign_sessions[1], "--out", out, "--pdf")
    assert proc.returncode == 0, proc.stderr
    # the page's and the PDF's paths first, then the next command (issue 38.5)
    lines = proc.stdout.splitlines()
    assert lines[:2] == [str(out / "report.html"), str(out / "report.pdf")], proc.stdout
    assert any(line.startswith("next:") for line in lines[2:]), proc.stdout
    record = json.loads((out / "record.json").read_text(encoding="utf-8"))
    pages = PdfReader(out / "report.pdf").pages
    assert len(pages) >= 2
    for number, page in enumerate(pages, start=1):
        text = page_text(page)
        assert f"Calibration record {record['id']}" in text
        assert f"page {number} of {len(pages)}" in text
        assert float(page.mediabox.height) == pytest.approx(841.9, abs=1.0)  # A4
    assert not list(out.glob(".*partial"))


def test_without_a_browser_the_pdf_is_refused_before_any_work(campaign_sessions, tmp_path,
                                                             monkeypatch, capsys):
    """The station's set-up, like a missing file: exit 2 before the report's seconds of
    work, and nothing written (issue 38.8: it was exit 3, after the page)."""
    monkeypatch.setenv("PATH", str(tmp_path / "empty"))  # no browser on it
    monkeypatch.delenv(BROWSER_ENV, raising=False)
    out = tmp_path / "out"
    assert main(["report", str(campaign_sessions[0]), "--out", str(out), "--pdf"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("ogacq: error: no Chromium found to print the PDF")
    assert len(err.splitlines()) == 1 and "apt-get install chromium" in err
    assert "leave out --pdf" in err
    assert not (out / "report.html").exists() and not (out / "report.pdf").exists()

    monkeypatch.setenv(BROWSER_ENV, str(tmp_path / "no-such-browser"))
    assert main(["report", str(campaign_sessions[0]), "--out", str(tmp_path / "b"),
                 "--pdf"]) == 2
    assert f"{BROWSER_ENV}={tmp_path / 'no-such-browser'} is not an executable" in \
        capsys.readouterr().err
