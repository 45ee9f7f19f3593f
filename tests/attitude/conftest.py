"""Short simulated passes shared by the attitude tests (each simulated once per session, a few seconds)."""
from __future__ import annotations

from pathlib import Path

import pytest

#: The "clean" pass of issue 6's Done-when: white noise only (phase 3 mm, code 0.3 m per receiver), no PCO/PCV,
#: no multipath. Seeds are fixed so a failure reproduces.
CLEAN = {"pcv": False, "pco": False, "multipath": False, "noise_grows_with_cn0": False}


def _simulate(tmp_path_factory, name: str, scenario: str, seed: int, overrides: dict) -> Path:
    from gnssatt.sim import simulate_scenario

    out = tmp_path_factory.mktemp(name)
    simulate_scenario(scenario, out, seed=seed, overrides=overrides)
    return out


def set_files(d: Path, with_sp3: bool = True, with_reference: bool = True) -> list[tuple[str, str, Path]]:
    """(name, kind, path) triples of a simulated set, as an observation set would list them."""
    files = [(f"obs/{p.name}", "rinex_obs", p) for p in sorted((d / "obs").glob("*.rnx"))]
    files += [("nav/brdc.rnx", "rinex_nav", d / "nav" / "brdc.rnx"), ("platform.json", "platform", d / "platform.json")]
    if with_sp3:
        files.append(("platform.sp3", "sp3", d / "platform.sp3"))
    if with_reference:
        files.append(("reference_attitude.csv", "reference_attitude", d / "reference_attitude.csv"))
    return files


@pytest.fixture(scope="session")
def clean_pass(tmp_path_factory) -> Path:
    return _simulate(tmp_path_factory, "clean", "earth-pointing", 11, {"duration_s": 360.0, **CLEAN})


@pytest.fixture(scope="session")
def slew_pass(tmp_path_factory) -> Path:
    return _simulate(tmp_path_factory, "slew", "slew", 2, {"duration_s": 360.0, **CLEAN})


@pytest.fixture(scope="session")
def hard_pass(tmp_path_factory) -> Path:
    return _simulate(tmp_path_factory, "hard", "hard", 2, {
        "duration_s": 300.0, "clock_free_drift_ppm": 5.0,
        "outage_windows": [["GPS-0", 100.0, 20.0], ["*", 200.0, 30.0]]})


@pytest.fixture(scope="session")
def realistic_pass(tmp_path_factory) -> Path:
    """The earth-pointing preset as it is: C/N0-dependent noise, multipath, PCV 10 mm p-p, PCO scatter."""
    return _simulate(tmp_path_factory, "realistic", "earth-pointing", 11, {"duration_s": 600.0})


#: seed 000 Fig. 6 (bottom), shortened: Earth pointing, pitch 0 -> 50 deg within one minute, then back to -40 deg
PITCH_SLEW = {"start_gps": "2018-06-06T16:31:00", "duration_s": 300.0,
              "waypoints": [[0.0, 0.0, 0.0, 0.0], [60.0, 0.0, 0.0, 0.0], [120.0, 0.0, 50.0, 0.0],
                            [300.0, 0.0, -40.0, 0.0]]}


@pytest.fixture(scope="session")
def pitch_slew_pass(tmp_path_factory) -> Path:
    return _simulate(tmp_path_factory, "pitch_slew", "slew", 0, {**PITCH_SLEW, **CLEAN})
