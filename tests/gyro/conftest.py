"""One short simulated seed 002 set shared by the gyro tests: 10 min of the Table 1 scenario (equatorial 650 km,
0.6 m square, 0.2 Hz L1, 10 Hz gyro) with GPS phase faults of 0.35 cycle every 60 s, a 30 s outage of all
satellites at 200 s and a 10x gyro drift step on the y axis from 400 s, fused once with the default settings."""
from __future__ import annotations

import pytest

from gnssatt.sim.gyro import DriftFault, GyroErrorModel
from gnssatt.sim.gyro_scenario import GyroScenario, simulate_gyro_set

GYRO_FAULT_START_S = 400.0
OUTAGE = (200.0, 30.0)


@pytest.fixture(scope="session")
def gyro_set(tmp_path_factory):
    sc = GyroScenario(duration_s=600.0, gps_fault_interval_s=60.0, outages=(OUTAGE,),
                      gyro=GyroErrorModel(faults=(DriftFault(axis=1, start_s=GYRO_FAULT_START_S,
                                                             size_rad_s=10 * 48.48e-6),)))
    return simulate_gyro_set(sc, tmp_path_factory.mktemp("gyro") / "set", seed=2)


@pytest.fixture(scope="session")
def fused(gyro_set):
    from gnssatt.gyro.api import fuse

    return fuse(gyro_set.files)
