"""Digest of every file four GPS-only simulated sets write (sha256 over names and contents): run it on two commits
to show that a change left GPS-only output byte-identical (GLONASS in the simulator, issue 21: 3fb151e3... before
and after). The sets: earth-pointing seed 3, ground-static seed 1, ground-static seed 4 from the real UPC nav file,
hard seed 2 with 5 ppm free clocks; 60-120 s each.

    .venv/bin/python bench/sim_gps_digest.py [--verbose]
"""
from __future__ import annotations

import argparse
import hashlib
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from bench.real_sets import REAL_DATA_DIR  # noqa: E402

UPC_NAV = REAL_DATA_DIR / "upc1_upc2_38m_barcelona_2010" / "brdc0770.11n"
CASES = [("earth-pointing", 3, {"duration_s": 120.0}), ("ground-static", 1, {"duration_s": 120.0}),
         ("ground-static", 4, {"nav_file": str(UPC_NAV), "start_gps": "2010-03-18T05:00:00", "duration_s": 60,
                               "lat_deg": 41.388922, "lon_deg": 2.112008, "height_m": 166.4}),
         ("hard", 2, {"duration_s": 120.0, "clock_free_drift_ppm": 5.0})]


def digest(verbose: bool = False) -> str:
    """sha256 over 'scenario/relative path:sha256 of the file' lines of every file of CASES, in sorted order."""
    from gnssatt.sim import simulate_scenario

    h = hashlib.sha256()
    for scenario, seed, overrides in CASES:
        with tempfile.TemporaryDirectory() as d:
            simulate_scenario(scenario, Path(d), seed=seed, overrides=overrides)
            for f in sorted(Path(d).rglob("*")):
                if f.is_file():
                    fh = hashlib.sha256(f.read_bytes()).hexdigest()
                    h.update(f"{scenario}/{f.relative_to(d)}:{fh}\n".encode())
                    if verbose:
                        print(scenario, seed, f.relative_to(d), fh[:12])
    return h.hexdigest()


if __name__ == "__main__":
    ap = argparse.ArgumentParser()
    ap.add_argument("--verbose", action="store_true")
    print(digest(ap.parse_args().verbose))
