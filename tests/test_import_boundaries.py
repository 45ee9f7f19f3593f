"""The science library never imports the service: each module of `gnssatt`, imported alone in a fresh process,
must not pull fastapi, starlette, sqlalchemy, huey, httpx, redis, psycopg, uvicorn or the service's own packages
(`core`, `app`, `worker`, `client`, `migrations`) into sys.modules. The shared persistence `core` (settings,
database, models, blobs, migrations runner, PCV-map store) imports neither of the two processes that share it
(`app`, `worker`), nor the CLI."""
from __future__ import annotations

import subprocess
import sys

import pytest

from tests.conftest import REPO_ROOT

FORBIDDEN = ("fastapi", "starlette", "sqlalchemy", "huey", "httpx", "redis", "psycopg", "uvicorn", "core", "app",
             "worker", "client", "migrations")
CORE_FORBIDDEN = ("app", "worker", "client", "fastapi", "huey")


def _modules(package: str) -> list[str]:
    return sorted(".".join(p.relative_to(REPO_ROOT).with_suffix("").parts).removesuffix(".__init__")
                  for p in (REPO_ROOT / package).rglob("*.py"))


SCIENCE = _modules("gnssatt")
CORE = _modules("core")


def _imported(module: str, roots: tuple[str, ...]) -> str:
    """The modules under `roots` that importing `module` alone, in a fresh process, puts in sys.modules."""
    code = (f"import sys, {module}\n"
            f"bad = sorted(m for m in sys.modules if m.split('.')[0] in {roots!r})\n"
            "print(','.join(bad))")
    out = subprocess.run([sys.executable, "-c", code], cwd=REPO_ROOT, capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    return out.stdout.strip()


def test_science_modules_found():
    assert "gnssatt.gnss.time" in SCIENCE and "gnssatt.gnss.io.sniff" in SCIENCE and "gnssatt.report" in SCIENCE
    assert "gnssatt" in SCIENCE


@pytest.mark.parametrize("module", SCIENCE)
def test_science_module_imports_no_web_code(module):
    bad = _imported(module, FORBIDDEN)
    assert bad == "", f"{module} imports web code: {bad}"


def test_core_modules_found():
    expected = {"core", "core.settings", "core.db", "core.models", "core.migrate", "core.blobs", "core.pcv_store"}
    assert expected <= set(CORE)


@pytest.mark.parametrize("module", CORE)
def test_core_module_imports_neither_app_nor_worker(module):
    bad = _imported(module, CORE_FORBIDDEN)
    assert bad == "", f"{module} imports {bad}"
