"""Plan satellite positions from a real navigation file (gnssatt.planning.satellites.positions_from_nav, used by
the plan job and bench/bench_plan_vs_attitude.py): every broadcast satellite of the Nagoya file, positions on its
system's orbit within the records' span, NaN where no record is valid."""
from __future__ import annotations

import numpy as np

from gnssatt.gnss.io.rinex_nav import read_rinex_nav
from gnssatt.gnss.time import GpsTime
from gnssatt.planning.satellites import positions_from_nav
from tests.conftest import missing

NAV = "static_1m_mosaicx5_nagoya_2024/base.nav"
#: semi-major axes (m) of the nominal orbits; a satellite's radius is within its orbit's eccentricity of them
#: (QZSS IGSO e ~0.075 and BeiDou GEO/IGSO at 42,164 km, MEO at 27,906 km)
RADII_M = {"G": (26_560e3,), "E": (29_600e3,), "J": (42_164e3,), "C": (27_906e3, 42_164e3)}


def test_positions_from_nav_on_the_real_nagoya_file(real_data_dir):
    path = real_data_dir / NAV
    if not path.is_file():
        missing(f"{path} not found")
    nav = read_rinex_nav(path)
    positions = positions_from_nav(nav)
    t0_s = int(min(int(np.min(k.toc.s)) for k in nav.kepler.values()))
    t = GpsTime(np.array([t0_s, t0_s + 1, t0_s + 3600, t0_s + 30 * 86400]), np.zeros(4))
    sats, r_ecef_m = positions(t)
    assert r_ecef_m.shape == (4, len(sats), 3)
    assert set(sats) == {str(x) for k in nav.kepler.values() for x in k.sat}
    radius_m = np.linalg.norm(r_ecef_m, axis=-1)
    ok = np.isfinite(radius_m[:3])
    assert ok.all(axis=0).sum() >= 20                      # most satellites have a valid record at the start
    for j, sat in enumerate(sats):
        if ok[:, j].all():
            # within 8 % of one of the system's orbit radii (IGSO eccentricity ~0.075)
            assert min(abs(radius_m[0, j] / a - 1) for a in RADII_M[sat[0]]) < 0.08, (sat, radius_m[0, j])
            speed_m_s = np.linalg.norm(r_ecef_m[1, j] - r_ecef_m[0, j])  # ECEF, 1 s apart
            assert 0.0 <= speed_m_s < 4_500.0, (sat, speed_m_s)
    assert np.isnan(r_ecef_m[3]).all()                     # 30 days after the file: no record valid
