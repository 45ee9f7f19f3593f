"""Science never imports the web side: each science module, imported alone in a fresh process, must not
pull fastapi, starlette, sqlalchemy, huey, httpx or the `app` package into sys.modules."""
from __future__ import annotations

import subprocess
import sys

import pytest

from tests.conftest import REPO_ROOT

FORBIDDEN = ("fastapi", "starlette", "sqlalchemy", "huey", "httpx", "app")
SCIENCE = sorted(
    ".".join(p.relative_to(REPO_ROOT).with_suffix("").parts)
    for root in ("worker/gnss", "worker/sim", "worker/estimation", "worker/attitude", "worker/calibration",
                 "worker/plots", "worker/ttff")
    if (REPO_ROOT / root).is_dir()
    for p in (REPO_ROOT / root).rglob("*.py")
)


SCIENCE.append("worker.report")


def test_science_modules_found():
    assert "worker.gnss.time" in SCIENCE and "worker.gnss.io.sniff" in SCIENCE


@pytest.mark.parametrize("module", SCIENCE)
def test_science_module_imports_no_web_code(module):
    code = (f"import sys, {module}\n"
            f"bad = sorted(m for m in sys.modules if m.split('.')[0] in {FORBIDDEN!r})\n"
            "print(','.join(bad))")
    out = subprocess.run([sys.executable, "-c", code], cwd=REPO_ROOT, capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "", f"{module} imports web code: {out.stdout.strip()}"
