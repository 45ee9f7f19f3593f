"""Browser fixtures: the real service (API + worker subprocesses, SQLite + Huey) and the SYSTEM Chromium driven
by Playwright. Playwright never downloads a browser here (`playwright install` is not used): it launches
/usr/bin/chromium (Debian package `chromium`; override with GNSSATT_CHROMIUM).

Without Chromium or the playwright package the browser tests skip with the reason, and fail under CI=true.
Setup: `apt-get install -y chromium` and `.venv/bin/pip install "playwright>=1.45"`.
"""
from __future__ import annotations

import importlib.util
import os
import shutil
from pathlib import Path

import pytest

from client.local_service import LocalService

REPO = Path(__file__).resolve().parents[2]
ARTIFACTS = REPO / "test-artifacts"
CHROMIUM = os.environ.get("GNSSATT_CHROMIUM", "/usr/bin/chromium")
CHROMIUM_ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
                 "--disable-background-networking", "--disable-component-update", "--disable-sync"]
SETUP = 'apt-get install -y chromium && .venv/bin/pip install "playwright>=1.45"'


def _unavailable(reason: str):
    if os.environ.get("CI", "").strip().lower() in ("1", "true", "yes"):
        pytest.fail(f"UI tests cannot run under CI: {reason}. Set up with: {SETUP}", pytrace=False)
    pytest.skip(f"UI browser tests not run: {reason} (set up with: {SETUP})")


@pytest.fixture(scope="module")
def browser():
    if importlib.util.find_spec("playwright") is None:
        _unavailable("the playwright Python package is not installed")
    path = CHROMIUM if os.path.isabs(CHROMIUM) else shutil.which(CHROMIUM)
    if not path or not os.access(path, os.X_OK):
        _unavailable(f"no Chromium executable at {CHROMIUM}")
    from playwright.sync_api import sync_playwright

    with sync_playwright() as pw:
        try:
            b = pw.chromium.launch(executable_path=path, args=CHROMIUM_ARGS, headless=True)
        except Exception as exc:  # noqa: BLE001 - a broken install is reported, never silently green
            _unavailable(f"Chromium at {path} does not start ({exc.__class__.__name__}: {str(exc)[:300]})")
        yield b
        b.close()


@pytest.fixture(scope="module")
def site(tmp_path_factory):
    """The real service on a free port (API + one worker), shared by the tests of a module."""
    svc = LocalService(tmp_path_factory.mktemp("ui"), "sqlite", None, None)
    try:
        svc.start_api()
        svc.start_worker()
        yield svc
    finally:
        svc.shutdown()


@pytest.fixture
def artifacts() -> Path:
    ARTIFACTS.mkdir(exist_ok=True)
    return ARTIFACTS


def sign_in(browser, site, key: str):
    """A fresh browser context signed in with `key`; returns (context, page) on the overview."""
    context = browser.new_context(base_url=site.url, viewport={"width": 1366, "height": 860},
                                  accept_downloads=True)
    context.set_default_timeout(30_000)
    page = context.new_page()
    errors: list[str] = []
    page.on("console", lambda m: errors.append(m.text) if m.type == "error" else None)
    page.on("pageerror", lambda e: errors.append(str(e)))
    page.on("response", lambda r: errors.append(f"HTTP {r.status} {r.url}") if r.status >= 400 else None)
    page.console_errors = errors
    page.goto("/ui")
    assert "/ui/login" in page.url
    page.fill("#api_key", key)
    page.click("#login-form button[type=submit]")
    page.wait_for_url(f"{site.url}/ui")
    return context, page
