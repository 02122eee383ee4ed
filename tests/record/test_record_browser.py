"""The record as a reader gets it: report.html opened in a real headless Chromium
(one start for this module), a screenshot of each section, the rendered text
checked against record.json, and the page printed to PDF by Chromium."""

from __future__ import annotations

import base64
import io
import json
import re

import pytest
from PIL import Image, ImageStat

from ogacq.cli.report_cmd import issue_report
from ogacq.session.store import load_session
from tests.record.browser import WINDOW, chromium, need_chromium, page_text
from tests.record.pages import gum, printed, unshown
from tests.record.sessions import HISTORY, INSTRUMENTS, OPERATOR, OVERRIDE_REASON

A4_PT = (595.3, 841.9)  # 210 x 297 mm


@pytest.fixture(scope="module")
def report(campaign_sessions, tmp_path_factory):
    """The report of the campaign with its context and two earlier calibrations."""
    folder = tmp_path_factory.mktemp("browser")
    page, _ = issue_report(load_session(campaign_sessions[1]), folder, history=HISTORY)
    return page, json.loads((folder / "record.json").read_text(encoding="utf-8"))


@pytest.fixture(scope="module")
def browser(report):
    need_chromium()
    with chromium() as driver:
        driver.get(report[0].resolve().as_uri())
        yield driver


def _text(browser) -> str:
    """The text as rendered (innerText: what is displayed, laid out)."""
    return " ".join(browser.execute_script("return document.body.innerText").split())


def test_the_rendered_page_shows_every_field_of_the_record(browser, report):
    _, record = report
    text = _text(browser)
    assert browser.title.startswith(f"Calibration record {record['id']}")
    assert unshown(record, text) == []
    for value in (record["id"], record["issued"], record["machine"]["name"],
                  record["machine"]["serial"], OPERATOR, OVERRIDE_REASON):
        assert value in text, value
    for instrument in INSTRUMENTS:
        assert instrument["serial"] in text and instrument["certificate"] in text
    for stage in ("start", "end"):
        assert str(record["environment"][stage]["ambient_c"]) in text
    for axis, result in record["results"]["joint_offset"].items():
        value, U = gum(result["value_mm"], result["U_mm"])  # the headline, JCGM 100 7.2.6
        assert f"joint_offset.{axis} {value} ± {U} mm (k = 2)" in text, axis
    for stage in ("as_found", "as_left"):
        assert record["acceptance"][stage]["decision"] in text
        # each deviation read as its U says: U to two digits, not record.json's nine
        for row in record["acceptance"][stage].get("rows") or []:
            value, U = gum(row["value_mm"], row["U_mm"])
            assert f"{value} {U}" in text, row
            assert printed(row["U_mm"]) == U or printed(row["U_mm"]) not in text, row
    for name, rows in (record["budget"] or {}).items():
        assert name in text and all(row["source"] in text for row in rows)
    # nothing left as a program wrote it: no None, NaN, undefined, dict or list dump
    # the history given: listed with U where it has one, and plotted
    assert "-1.2391 ± 0.0041" in text and "-1.2417" in text
    assert browser.find_element("css selector", 'img[alt^="Each parameter at each"]')
    assert not re.search(r"\bNone\b|\bnan\b|\bundefined\b|\{'|\[\{|\['", text)


def test_a_screenshot_of_each_section_is_a_real_picture(browser, report, tmp_path):
    assert browser.execute_script(
        "return Array.from(document.images).every(i => i.complete && i.naturalWidth > 0)")
    headings = browser.find_elements("css selector", "h2")
    names = [h.get_attribute("id") for h in headings]
    assert {"identification", "instruments", "environment", "method", "results",
            "acceptance", "budget", "monte-carlo", "history", "overrides", "adjustment",
            "sign-off"} <= set(names)
    for heading, name in zip(headings, names, strict=True):
        browser.execute_script("arguments[0].scrollIntoView()", heading)
        png = browser.get_screenshot_as_png()
        (tmp_path / f"{name}.png").write_bytes(png)  # kept for a person to look at
        with Image.open(io.BytesIO(png)) as shot:
            width, height = shot.size
            assert width >= WINDOW[0] * 0.9 and height >= WINDOW[1] * 0.5, (name, shot.size)
            pixels = shot.convert("L")
            colours = len(shot.convert("RGB").getcolors(maxcolors=1 << 20) or ())
            assert ImageStat.Stat(pixels).stddev[0] > 10 and colours > 20, name  # not blank
        # the section is on the screen: its heading's top inside the viewport
        top = browser.execute_script("return arguments[0].getBoundingClientRect().top", heading)
        assert -1 <= top < height, name


def test_the_printout_is_a4_with_the_record_id_on_every_page(browser, report, tmp_path):
    from pypdf import PdfReader

    _, record = report
    printed = browser.execute_cdp_cmd("Page.printToPDF", {"preferCSSPageSize": True,
                                                          "printBackground": True})
    pdf = base64.b64decode(printed["data"])
    (tmp_path / "record.pdf").write_bytes(pdf)
    pages = PdfReader(io.BytesIO(pdf)).pages
    assert len(pages) >= 2
    texts = [page_text(page) for page in pages]
    for number, (page, text) in enumerate(zip(pages, texts, strict=True), start=1):
        size = (float(page.mediabox.width), float(page.mediabox.height))
        assert size == pytest.approx(A4_PT, abs=1.0)
        assert f"Calibration record {record['id']}" in text, number
        assert f"page {number} of {len(pages)}" in text, number
    everything = " ".join(texts)
    # a table cell may wrap on the printed page (the extracted text then has a space
    # at the break): the value is there whatever the spacing
    unspaced = "".join(everything.split())
    for value in (record["machine"]["serial"], OPERATOR, OVERRIDE_REASON,
                  *(i["certificate"] for i in INSTRUMENTS)):
        assert "".join(value.split()) in unspaced, value
    assert f"End of calibration record {record['id']}" in texts[-1]
