"""The report printed to PDF by a headless Chromium, as a person's browser would print
it: the page's print stylesheet decides the paper (A4), the margins, the page
breaks and the running header and footer (record id, issue date, page n of N).
"""

from __future__ import annotations

import os
import shutil
import subprocess
import tempfile
from pathlib import Path

from ogacq.errors import OgacqError

BROWSER_ENV = "OGACQ_BROWSER"  # the browser to print with, when not on the PATH
BROWSER_NAMES = ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable")
PRINT_TIMEOUT_S = 120.0  # a cold start on a loaded machine takes seconds, not minutes

# A closed network stalls a Chromium that phones home: nothing it would fetch is needed
# for a self-contained page.
QUIET_FLAGS = ("--headless", "--disable-gpu", "--disable-quic", "--no-first-run",
               "--disable-background-networking", "--disable-component-update",
               "--disable-sync", "--disable-extensions", "--mute-audio")


class PrintError(OgacqError):
    """The browser failed to print the PDF: a fault of the station (exit 3, like a disk
    that cannot be written); the HTML report is written before and stays."""

    exit_code = 3


class NoBrowser(PrintError):
    """No browser to print with: the station's set-up, found before any work starts
    (exit 2, as a missing file is)."""

    exit_code = 2


def find_browser() -> str:
    """The Chromium to print with: ``$OGACQ_BROWSER``, else the first of
    :data:`BROWSER_NAMES` on the PATH; PrintError naming what was looked for."""
    named = os.getenv(BROWSER_ENV)
    for name in [named] if named else BROWSER_NAMES:
        found = shutil.which(name)
        if found is not None:
            return found
    if named:
        raise NoBrowser(f"{BROWSER_ENV}={named} is not an executable browser: "
                        "cannot print the PDF")
    raise NoBrowser(f"no Chromium found to print the PDF (looked for {', '.join(BROWSER_NAMES)} "
                    f"on the PATH, and {BROWSER_ENV}); install Chromium (Debian: apt-get "
                    "install chromium), or leave out --pdf and print report.html from a "
                    "browser")


def browser_flags(user_data_dir: str | Path) -> list[str]:
    flags = [*QUIET_FLAGS, f"--user-data-dir={user_data_dir}"]
    if hasattr(os, "geteuid") and os.geteuid() == 0:
        # Chromium's sandbox refuses to run as root; the page is our own, without script
        flags.append("--no-sandbox")
    return flags


def print_pdf(html: Path, pdf: Path, browser: str | None = None) -> Path:
    """Print ``html`` to ``pdf`` (replaced whole: a failed print leaves no partial
    file); returns ``pdf``."""
    browser = browser or find_browser()
    pdf = Path(pdf)
    partial = pdf.with_name(f".{pdf.name}.partial")
    with tempfile.TemporaryDirectory(prefix="ogacq-print-") as profile:
        command = [browser, *browser_flags(profile), "--no-pdf-header-footer",
                   f"--print-to-pdf={partial}", Path(html).resolve().as_uri()]
        try:
            done = subprocess.run(command, capture_output=True, text=True,
                                  timeout=PRINT_TIMEOUT_S, stdin=subprocess.DEVNULL)
        except subprocess.TimeoutExpired:
            partial.unlink(missing_ok=True)
            raise PrintError(f"{browser} did not print {html} within "
                             f"{PRINT_TIMEOUT_S:.0f} s") from None
        except OSError as exc:
            raise PrintError(f"cannot start {browser}: {exc.strerror or exc}") from None
    if done.returncode != 0 or not _is_pdf(partial):
        partial.unlink(missing_ok=True)
        last = (done.stderr.strip().splitlines() or ["no message"])[-1]
        raise PrintError(f"{browser} failed to print {html} (exit {done.returncode}: {last})")
    try:
        os.replace(partial, pdf)
    except OSError as exc:
        partial.unlink(missing_ok=True)
        raise PrintError(f"{pdf}: cannot write the PDF ({exc.strerror or exc})") from None
    return pdf


def _is_pdf(path: Path) -> bool:
    try:
        with open(path, "rb") as f:
            return f.read(5) == b"%PDF-"
    except OSError:
        return False
