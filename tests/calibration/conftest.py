"""Calibration fixtures: the simulated campaign more than one module reads, simulated once per run."""
from __future__ import annotations

from pathlib import Path

import pytest

from gnssatt.calibration.simulated import simulate_campaign

BENIGN = {"noise": False, "multipath": False, "cn0_jitter_db": 0.0}


@pytest.fixture(scope="session")
def benign_campaign_4x600(tmp_path_factory) -> list[Path]:
    """Four 10-minute benign passes (no noise, no multipath) with the preset's offsets, PCO and 35 mm PCV, seed 11.
    Read-only: a test that changes a set copies it first."""
    return simulate_campaign(tmp_path_factory.mktemp("cal_benign_4x600"), 4, 600.0, seed=11, overrides=BENIGN)
