"""Shared fixtures: where the real recorded data lives, and temp dirs."""
from __future__ import annotations

from pathlib import Path

import pytest

from bench.real_sets import REAL_DATA_DIR

REPO_ROOT = Path(__file__).resolve().parents[1]


def real_set(name: str) -> Path:
    """Path of one real data set under ../shared/data/real; skip with the reason when absent."""
    path = REAL_DATA_DIR / name
    if not path.is_dir():
        pytest.skip(f"real data set {name!r} not found at {path} (../shared/data/real is not beside the repo)")
    return path


@pytest.fixture
def real_data_dir() -> Path:
    if not REAL_DATA_DIR.is_dir():
        pytest.skip(f"real data not found at {REAL_DATA_DIR} (../shared is not beside the repo)")
    return REAL_DATA_DIR
