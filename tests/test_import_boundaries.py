"""The science library never imports the service: each module of `gnssatt`, imported alone in a fresh process,
must not pull fastapi, starlette, sqlalchemy, huey, httpx, redis, psycopg, uvicorn or the service's own packages
(`app`, `worker`, `client`, `migrations`) into sys.modules."""
from __future__ import annotations

import subprocess
import sys

import pytest

from tests.conftest import REPO_ROOT

FORBIDDEN = ("fastapi", "starlette", "sqlalchemy", "huey", "httpx", "redis", "psycopg", "uvicorn", "app",
             "worker", "client", "migrations")
SCIENCE = sorted(
    ".".join(p.relative_to(REPO_ROOT).with_suffix("").parts).removesuffix(".__init__")
    for p in (REPO_ROOT / "gnssatt").rglob("*.py")
)


def test_science_modules_found():
    assert "gnssatt.gnss.time" in SCIENCE and "gnssatt.gnss.io.sniff" in SCIENCE and "gnssatt.report" in SCIENCE
    assert "gnssatt" in SCIENCE


@pytest.mark.parametrize("module", SCIENCE)
def test_science_module_imports_no_web_code(module):
    code = (f"import sys, {module}\n"
            f"bad = sorted(m for m in sys.modules if m.split('.')[0] in {FORBIDDEN!r})\n"
            "print(','.join(bad))")
    out = subprocess.run([sys.executable, "-c", code], cwd=REPO_ROOT, capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "", f"{module} imports web code: {out.stdout.strip()}"
