"""GLONASS broadcast orbits (gnssatt.gnss.orbits.glonass): the ICD 5.1 A.3.1.2 integration against the next record's
broadcast state vector and an independent scalar integration, and BroadcastEphemeris serving GLONASS."""
from __future__ import annotations

import math

import numpy as np

from tests.conftest import real_set
from gnssatt.gnss.ephemeris import BroadcastEphemeris
from gnssatt.gnss.io.rinex_nav import read_rinex_nav
from gnssatt.gnss.orbits.glonass import glonass_state_ecef
from gnssatt.gnss.time import GpsTime

NAGOYA = "static_1m_mosaicx5_nagoya_2024"


def _nav():
    return read_rinex_nav(real_set(NAGOYA) / "base.nav")


def _scalar_deriv(y, acc):
    """ICD 5.1 A.3.1.2 written out term by term, plain floats (km-free SI)."""
    mu, ae, j2, w = 398600.4418e9, 6378136.0, 1082.62575e-6, 7.292115e-5
    x, yy, z, vx, vy, vz = y
    r = math.sqrt(x * x + yy * yy + z * z)
    k = 1.5 * j2 * mu * ae * ae / r ** 5
    zz = 5.0 * z * z / (r * r)
    ax = -mu / r ** 3 * x - k * x * (1 - zz) + w * w * x + 2 * w * vy + acc[0]
    ay = -mu / r ** 3 * yy - k * yy * (1 - zz) + w * w * yy - 2 * w * vx + acc[1]
    az = -mu / r ** 3 * z - k * z * (3 - zz) + acc[2]
    return [vx, vy, vz, ax, ay, az]


def test_thirty_minutes_ahead_meets_the_next_broadcast_state():
    """Each record integrated to the next record's t_b (30 min) lands within 10 m and 1 cm/s of that record's
    state: the broadcast fit (the records are fitted arcs, a few m apart at their edges: 1.4-4.8 m measured)."""
    g = _nav().glonass
    n_pairs = 0
    for sat in np.unique(g.sat):
        ii = np.flatnonzero(g.sat == sat)
        for a, b in zip(ii[:-1], ii[1:]):
            r, v, _, _ = glonass_state_ecef(g, np.array([a]), g.toc[np.array([b])])
            assert np.linalg.norm(r[0] - g.position_m[b]) < 10.0
            assert np.linalg.norm(v[0] - g.velocity_m_s[b]) < 0.01
            n_pairs += 1
    assert n_pairs >= 8


def test_against_a_scalar_rk4_with_ten_second_steps():
    """The vectorised 60 s RK4 against a scalar RK4 with 10 s steps over 15 min: within 1 mm (step error)."""
    g = _nav().glonass
    y = list(g.position_m[0]) + list(g.velocity_m_s[0])
    acc = g.acceleration_m_s2[0]
    h = 10.0
    for _ in range(90):
        k1 = _scalar_deriv(y, acc)
        k2 = _scalar_deriv([a + 0.5 * h * b for a, b in zip(y, k1)], acc)
        k3 = _scalar_deriv([a + 0.5 * h * b for a, b in zip(y, k2)], acc)
        k4 = _scalar_deriv([a + h * b for a, b in zip(y, k3)], acc)
        y = [a + h / 6 * (p + 2 * q + 2 * r + s) for a, p, q, r, s in zip(y, k1, k2, k3, k4)]
    t = GpsTime(np.array([g.toc.s[0] + 900]), np.array([g.toc.frac[0]]))
    r, v, clk, rate = glonass_state_ecef(g, np.array([0]), t)
    assert np.linalg.norm(r[0] - np.array(y[:3])) < 1e-3
    assert abs(clk[0] - (-g.tau_n_s[0] + g.gamma_n[0] * 900.0)) < 1e-15


def test_broadcast_ephemeris_serves_glonass():
    nav = _nav()
    eph = BroadcastEphemeris(nav)
    t0 = nav.glonass.toc[0]
    st = eph.state(["R01", "R03", "R02", "R99"], GpsTime(np.full(4, t0.s + 300), np.zeros(4)))
    assert st.valid.tolist() == [True, True, False, False]      # R02 broadcasts B_n = 1 (unhealthy)
    assert BroadcastEphemeris(nav, allow_unhealthy=True).state(["R02"], GpsTime(np.array([t0.s]), np.zeros(1))).valid[0]
    radius = np.linalg.norm(st.r_ecef_m[:2], axis=1)
    assert np.all(np.abs(radius - 25.5e6) < 0.2e6)              # GLONASS orbit radius 25 510 km
    far = eph.state(["R01"], GpsTime(np.array([t0.s + 10 * 86400]), np.zeros(1)))
    assert not far.valid[0]                                     # no record within 30 min
