"""report.html -> PDF with the system Chromium through Playwright (page.pdf), when both are installed; PDFs are
kept in a small in-process cache keyed by the report's SHA-256 (a report never changes once stored).

Chromium: GNSSATT_CHROMIUM or /usr/bin/chromium (Debian package `chromium`); no browser is downloaded."""
from __future__ import annotations

import importlib.util
import os
import shutil
import threading
from collections import OrderedDict
from pathlib import Path

_CACHE: OrderedDict[str, bytes] = OrderedDict()
_CACHE_MAX = 16
_LOCK = threading.Lock()
ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--no-first-run", "--disable-background-networking",
        "--disable-component-update", "--disable-sync"]


class PdfUnavailable(RuntimeError):
    """No Chromium or no playwright package: the PDF cannot be made here."""


def chromium_path() -> str | None:
    name = os.environ.get("GNSSATT_CHROMIUM", "/usr/bin/chromium")
    path = name if os.path.isabs(name) else shutil.which(name)
    return path if path and os.access(path, os.X_OK) else None


def available() -> bool:
    return chromium_path() is not None and importlib.util.find_spec("playwright") is not None


def pdf_of(html_path: Path, sha256: str) -> bytes:
    """A4 PDF of the self-contained HTML file (printed backgrounds); raises PdfUnavailable."""
    with _LOCK:
        if sha256 in _CACHE:
            _CACHE.move_to_end(sha256)
            return _CACHE[sha256]
    if not available():
        raise PdfUnavailable("The server has no Chromium/Playwright to print the report; download report.html and "
                             "print it from a browser.")
    from playwright.sync_api import sync_playwright

    with sync_playwright() as pw:
        browser = pw.chromium.launch(executable_path=chromium_path(), args=ARGS, headless=True)
        try:
            page = browser.new_page()
            # the report has no external URL: nothing is fetched (offline, no requests leave the machine)
            page.route("**/*", lambda route: route.abort())
            page.set_content(Path(html_path).read_text(), wait_until="load")
            data = page.pdf(format="A4", print_background=True,
                            margin={"top": "12mm", "bottom": "12mm", "left": "10mm", "right": "10mm"})
        finally:
            browser.close()
    with _LOCK:
        _CACHE[sha256] = data
        while len(_CACHE) > _CACHE_MAX:
            _CACHE.popitem(last=False)
    return data
