"""A real headless Chromium for the record's tests, driven through selenium and its
chromedriver (the Debian packages chromium and chromium-driver; CI installs them).

Without a browser the tests are skipped on a developer's machine, never under CI
(CI=true), where a missing browser is a failure.
"""

from __future__ import annotations

import os
import shutil
import tempfile
import unicodedata
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

import pytest

CHROMIUM = "/usr/bin/chromium"
CHROMEDRIVER = "/usr/bin/chromedriver"
# A closed network stalls a Chromium that phones home (updates, sync, QUIC probes).
FLAGS = ("--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
         "--disable-background-networking", "--disable-component-update", "--disable-sync",
         "--disable-extensions", "--hide-scrollbars", "--force-device-scale-factor=1")
WINDOW = (1200, 1000)  # css px: the page's 1120 px column and its margins


def page_text(page: Any) -> str:
    """A printed page's text, its whitespace runs made one space. NFKC: Chromium's
    font sets "ff" and "fi" as ligatures, which the text layer gives as U+FB00 and
    U+FB01, so a record id holding "ff" (1 in ~37 hex ids) read as another id."""
    return " ".join(unicodedata.normalize("NFKC", page.extract_text()).split())


def need_chromium() -> None:
    """Skip without Chromium, except under CI."""
    present = os.path.exists(CHROMIUM) and os.path.exists(CHROMEDRIVER)
    if not present and os.environ.get("CI") != "true":
        pytest.skip(f"no {CHROMIUM} and {CHROMEDRIVER} (apt-get install chromium "
                    "chromium-driver)")


@contextmanager
def chromium() -> Iterator:
    """One headless Chromium with a fresh profile, closed on exit."""
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    profile = tempfile.mkdtemp(prefix="ogacq-chromium-")
    options = webdriver.ChromeOptions()
    options.binary_location = CHROMIUM
    for flag in (*FLAGS, f"--user-data-dir={profile}", f"--window-size={WINDOW[0]},{WINDOW[1]}"):
        options.add_argument(flag)
    driver = webdriver.Chrome(service=Service(CHROMEDRIVER), options=options)
    try:
        driver.set_page_load_timeout(60)
        yield driver
    finally:
        driver.quit()
        shutil.rmtree(profile, ignore_errors=True)
