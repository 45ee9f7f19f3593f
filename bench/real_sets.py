"""The real recorded data sets the tests and benchmarks run on: where they live and the platforms that describe them
(the sets carry RINEX files only). Shared by tests/attitude (test_real_nagoya, test_real_upc, ...) and bench/
(bench_attitude_rtklib, bench_products_identity); tests may import it, it imports nothing of tests.

The data sit in ../shared/data/real beside the repository, or under $GNSSATT_SHARED_DIR/data/real.
"""
from __future__ import annotations

import os
from pathlib import Path

import numpy as np

REPO_ROOT = Path(__file__).resolve().parents[1]
SHARED_DIR = Path(os.environ.get("GNSSATT_SHARED_DIR", REPO_ROOT.parent / "shared"))
REAL_DATA_DIR = SHARED_DIR / "data" / "real"

#: one 0.99 m baseline, static, Septentrio mosaic-X5, 5 min at 1 Hz (the set's README: RTKLIB 2.4.3 b34 fixed
#: solution length 0.9902 m, azimuth 193.03 deg, elevation 0.56 deg)
NAGOYA = "static_1m_mosaicx5_nagoya_2024"
NAGOYA_PLATFORM = {
    "name": "nagoya-dual", "kind": "terrestrial",
    # a tape-measured 0.99 m along the vehicle x axis: only the length matters for one baseline
    "antennas": {"base": {"position_m": [0.0, 0.0, 0.0], "boresight": [0, 0, -1]},
                 "rover": {"position_m": [0.99, 0.0, 0.0], "boresight": [0, 0, -1]}},
    "master": "base", "baselines": [["base", "rover"]],
    # both files carry MARKER NAME "SEPT", so the mapping must be explicit
    "observation_files": {"base": "base.obs", "rover": "rover.obs"},
}

#: one 38 m baseline on a roof in Barcelona, 1 h at 1 Hz, GPS L1+L2 (gAGE/UPC tutorial data)
UPC = "upc1_upc2_38m_barcelona_2010"
#: the set's README, UPC1 -> UPC2 in ENU at UPC1, m (reference coordinates of the tutorial)
UPC_ENU_M = np.array([-27.4171, -26.2340, -0.0306])
UPC_PLATFORM = {
    "name": "upc-roof", "kind": "terrestrial",
    # body = NED of a level vehicle heading north: (N, E, D) of the README vector; only its length is used
    "antennas": {"UPC1": {"position_m": [0.0, 0.0, 0.0], "boresight": [0, 0, -1]},
                 "UPC2": {"position_m": [float(UPC_ENU_M[1]), float(UPC_ENU_M[0]), float(-UPC_ENU_M[2])],
                          "boresight": [0, 0, -1]}},
    "master": "UPC1", "baselines": [["UPC1", "UPC2"]],
    "observation_files": {"UPC1": "UPC10770.11o.gz", "UPC2": "UPC20770.11o.gz"},
}


def nagoya_files(d: Path, platform_json: Path) -> list[tuple[str, str, Path]]:
    """(name, kind, path) of the Nagoya set d with the platform file platform_json (NAGOYA_PLATFORM written out)."""
    return [("base.obs", "rinex_obs", d / "base.obs"), ("rover.obs", "rinex_obs", d / "rover.obs"),
            ("base.nav", "rinex_nav", d / "base.nav"), ("platform.json", "platform", platform_json)]


def upc_files(d: Path, platform_json: Path) -> list[tuple[str, str, Path]]:
    """(name, kind, path) of the UPC set d with the platform file platform_json (UPC_PLATFORM written out)."""
    return [("UPC10770.11o.gz", "rinex_obs", d / "UPC10770.11o.gz"),
            ("UPC20770.11o.gz", "rinex_obs", d / "UPC20770.11o.gz"),
            ("brdc0770.11n", "rinex_nav", d / "brdc0770.11n"), ("platform.json", "platform", platform_json)]
