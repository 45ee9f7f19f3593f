"""Under CI=true a skip for missing input fails, naming what is missing (tests/conftest.py hooks); outside CI
it stays a skip. Run on throw-away test files in a subprocess, with the repo's conftest."""
from __future__ import annotations

import os
import subprocess
import sys

from tests.conftest import REPO_ROOT

PLAIN_SKIP = 'import pytest\n\ndef test_a():\n    pytest.skip("forgotten plain skip of data set XYZ")\n'
MODULE_SKIP = 'import pytest\npytest.importorskip("no_such_package_zz")\n\ndef test_b():\n    pass\n'


def _run(tmp_name: str, body: str, ci: str) -> subprocess.CompletedProcess:
    path = REPO_ROOT / "tests" / tmp_name
    path.write_text(body)
    try:
        env = {**os.environ, "CI": ci, "PYTHONPATH": str(REPO_ROOT)}
        return subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", str(path)],
                              cwd=REPO_ROOT, env=env, capture_output=True, text=True, timeout=120)
    finally:
        path.unlink()


def test_plain_skip_fails_under_ci_and_names_the_reason():
    res = _run("test_zz_ci_plain.py", PLAIN_SKIP, "true")
    assert res.returncode != 0 and "1 failed" in res.stdout, res.stdout
    assert "forgotten plain skip of data set XYZ" in res.stdout
    res = _run("test_zz_ci_plain.py", PLAIN_SKIP, "")
    assert res.returncode == 0 and "1 skipped" in res.stdout, res.stdout


def test_module_level_skip_fails_under_ci():
    res = _run("test_zz_ci_module.py", MODULE_SKIP, "true")
    assert res.returncode != 0 and "no_such_package_zz" in res.stdout, res.stdout
