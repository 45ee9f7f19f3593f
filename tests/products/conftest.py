"""A short simulated pass (preset earth-pointing, 300 s, three antennas, reference attitude) solved once per
session, and its products, for the quality, export and chart-series tests."""
from __future__ import annotations

from pathlib import Path

import pytest


@pytest.fixture(scope="session")
def short_pass(tmp_path_factory):
    from gnssatt.attitude import solve
    from gnssatt.attitude.products import all_products
    from gnssatt.sim import simulate_scenario

    out = tmp_path_factory.mktemp("pass300")
    simulate_scenario("earth-pointing", out, overrides={"duration_s": 300})
    files = sorted(p for p in out.rglob("*") if p.is_file() and "truth" not in p.relative_to(out).parts)
    sol = solve(files)
    return {"dir": Path(out), "sol": sol, "products": all_products(sol, creation_date="2026-12-02T05:00:00")}
