"""`.ci/run` first checks the shared inputs (.ci/check-inputs): under CI=true a missing ../shared/data/real stops
the run before anything is installed, naming the path; outside CI it is a note and the tests that need it skip."""
from __future__ import annotations

import os
import subprocess

from bench.real_sets import REAL_DATA_DIR
from tests.conftest import REPO_ROOT


def _check(shared_dir, ci: str) -> subprocess.CompletedProcess:
    env = {**os.environ, "CI": ci, "GNSSATT_SHARED_DIR": str(shared_dir)}
    return subprocess.run(["bash", str(REPO_ROOT / ".ci" / "check-inputs")], env=env, capture_output=True,
                          text=True, timeout=30)


def test_missing_shared_fails_under_ci_and_names_the_path(tmp_path):
    res = _check(tmp_path / "no-shared", "true")
    assert res.returncode == 2, res.stderr
    assert str(tmp_path / "no-shared" / "data" / "real") in res.stderr


def test_an_empty_data_dir_counts_as_missing(tmp_path):
    (tmp_path / "data" / "real").mkdir(parents=True)
    assert _check(tmp_path, "true").returncode == 2


def test_outside_ci_it_is_a_note(tmp_path):
    res = _check(tmp_path / "no-shared", "")
    assert res.returncode == 0 and "will skip" in res.stderr


def test_the_real_shared_dir_passes():
    res = _check(REAL_DATA_DIR.parents[1], "true")
    assert res.returncode == 0, res.stderr
