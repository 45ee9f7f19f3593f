"""The simulator's constellation can come from a real navigation file: the simulated orbits are then the
broadcast model of that file's records (issue 5: "GPS from a navigation file or a synthetic one")."""
from __future__ import annotations

import numpy as np

from tests.conftest import real_set
from gnssatt.gnss.ephemeris import BroadcastEphemeris
from gnssatt.gnss.io.rinex_nav import read_rinex_nav
from gnssatt.gnss.orbits.broadcast import kepler_position_ecef
from gnssatt.gnss.time import GpsTime
from gnssatt.sim import simulate_scenario
from gnssatt.sim.constellation import gps_from_nav


def test_model_reproduces_the_real_records():
    nav_path = real_set("upc1_upc2_38m_barcelona_2010") / "brdc0770.11n"
    t0 = GpsTime.from_calendar(2010, 3, 18, 5, 10, 0.0)
    const = gps_from_nav(nav_path, t0)
    kep = read_rinex_nav(nav_path).kepler["G"]
    dt = np.array([0.0, 900.0, 1800.0])
    r_model, clk_model = const.position_clock(float(t0 - const.t_ref) + dt[:, None] + np.zeros((1, const.n)))
    for j, sat in enumerate(const.sats):
        rows = np.flatnonzero(kep.sat == sat)
        best = rows[np.argmin([abs(float(kep.toe_gpst()[i] - t0)) for i in rows])]
        for k, d in enumerate(dt):
            r, _, clk, _ = kepler_position_ecef(kep, np.array([best]), t0 + d, apply_tgd=False)
            assert np.linalg.norm(r[0] - r_model[k, j]) < 1e-3  # m
            assert abs(clk[0] - clk_model[k, j]) < 1e-12  # s


def test_simulated_nav_matches_the_real_orbits(tmp_path):
    nav_path = real_set("upc1_upc2_38m_barcelona_2010") / "brdc0770.11n"
    simulate_scenario("ground-static", tmp_path, seed=1, overrides={
        "nav_file": str(nav_path), "start_gps": "2010-03-18T05:00:00", "duration_s": 60,
        "lat_deg": 41.388922, "lon_deg": 2.112008, "height_m": 166.4})
    written = BroadcastEphemeris(read_rinex_nav(tmp_path / "nav" / "brdc.rnx"))
    real = BroadcastEphemeris(read_rinex_nav(nav_path))
    t = GpsTime.from_calendar(2010, 3, 18, 5, 0, 30.0)
    sats = sorted(set(read_rinex_nav(tmp_path / "nav" / "brdc.rnx").kepler["G"].sat.tolist()))
    a, b = written.state(sats, t), real.state(sats, t)
    both = a.valid & b.valid
    assert len(sats) >= 20 and both.sum() >= 8
    # The real file may hold a neighbouring record (2 h apart) of the same satellite at this time:
    # consecutive broadcast records agree to metres, and a wrong satellite or epoch would be thousands of km off.
    assert np.max(np.linalg.norm(a.r_ecef_m[both] - b.r_ecef_m[both], axis=1)) < 10.0
    assert "brdc0770.11n" in (tmp_path / "nav" / "brdc.rnx").read_text()[:2000]


def test_passes_of_one_run_share_the_antennas(tmp_path):
    """A multi-pass run is one platform: the injected PCV maps and PCOs are the same in every pass (a calibration
    campaign over passes with different hardware would be meaningless), while noise differs."""
    import json

    simulate_scenario("calibration", tmp_path, seed=4, overrides={"count": 2, "duration_s": 30})
    a, b = tmp_path / "pass_000", tmp_path / "pass_001"
    for name in sorted(p.name for p in (a / "truth" / "pcv").glob("*.json")):
        assert json.loads((a / "truth" / "pcv" / name).read_text()) == json.loads((b / "truth" / "pcv" / name).read_text())
    ma, mb = (json.loads((d / "truth" / "model.json").read_text())["antennas"] for d in (a, b))
    for ant in ma:
        assert ma[ant]["pco_ant_m"] == mb[ant]["pco_ant_m"]
        assert ma[ant]["offset_body_m"] == mb[ant]["offset_body_m"]
    assert (a / "obs" / "GPS-0.rnx").read_bytes() != (b / "obs" / "GPS-0.rnx").read_bytes()
