"""Shared fixtures: where the real recorded data lives, and temp dirs; under CI=true no test skips for missing input.

Under CI=true (`.ci/run`, any CI service) a skip FAILS, naming what is missing: the hooks below turn every skipped
test or test module into a failure, so a forgotten `pytest.skip` cannot hide a gap. A skip that is not about
missing input (none today) must say so with a reason starting with NOT_MISSING_INPUT.
Use `missing(reason)` and `require_module(name)` instead of pytest.skip / pytest.importorskip."""
from __future__ import annotations

import importlib
import os
from pathlib import Path

import pytest

from bench.real_sets import REAL_DATA_DIR

REPO_ROOT = Path(__file__).resolve().parents[1]
CI = os.environ.get("CI", "").strip().lower() in ("1", "true", "yes")
NOT_MISSING_INPUT = "not missing input:"


def missing(reason: str):
    """Skip for a missing input (data set, package, program); under CI=true fail with the same reason."""
    if CI:
        pytest.fail(f"CI=true and a required input is missing: {reason}", pytrace=False)
    pytest.skip(reason)


def require_module(name: str, why: str = ""):
    """Import and return module `name`, or `missing(...)` naming it (pytest.importorskip that fails under CI)."""
    try:
        return importlib.import_module(name)
    except ImportError as exc:
        missing(f"Python package {name!r} not importable ({exc}){': ' + why if why else ''}")


def _skip_reason(longrepr) -> str:
    return longrepr[2] if isinstance(longrepr, tuple) and len(longrepr) == 3 else str(longrepr)


def _fail_skip_under_ci(report) -> None:
    if CI and report.skipped and not hasattr(report, "wasxfail"):
        reason = _skip_reason(report.longrepr)
        if NOT_MISSING_INPUT not in reason:
            report.outcome = "failed"
            report.longrepr = f"CI=true: this would have been skipped, which CI does not allow: {reason}"


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_makereport(item, call):
    outcome = yield
    _fail_skip_under_ci(outcome.get_result())


@pytest.hookimpl(hookwrapper=True)
def pytest_make_collect_report(collector):
    outcome = yield
    _fail_skip_under_ci(outcome.get_result())


def real_set(name: str) -> Path:
    """Path of one real data set under ../shared/data/real; `missing` (skip, or fail under CI=true) when absent."""
    path = REAL_DATA_DIR / name
    if not path.is_dir():
        missing(f"real data set {name!r} not found at {path} (../shared/data/real is not beside the repo)")
    return path


@pytest.fixture
def real_data_dir() -> Path:
    if not REAL_DATA_DIR.is_dir():
        missing(f"real data not found at {REAL_DATA_DIR} (../shared is not beside the repo)")
    return REAL_DATA_DIR
