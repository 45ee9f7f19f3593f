"""Gravity with J2 against normal gravity, the specific force of simple motions, IGRF-14 frames and dates."""
from __future__ import annotations

import datetime as dt

import numpy as np
import pytest

from gnssatt.gnss.frames import R_ned_from_ecef, geodetic_to_ecef
from gnssatt.single_antenna.differentiate import filter_series
from gnssatt.single_antenna.gravity import OMEGA_ECEF_RAD_S, specific_force_ecef_m_s2

from tests.conftest import require_module


def _somigliana(lat_rad):
    """WGS 84 normal gravity on the ellipsoid (NIMA TR8350.2 eq. 4-1), m/s^2."""
    ge, k, e2 = 9.7803253359, 0.00193185265241, 0.00669437999013
    s2 = np.sin(lat_rad) ** 2
    return ge * (1 + k * s2) / np.sqrt(1 - e2 * s2)


def test_static_specific_force_is_normal_gravity_upwards():
    for lat in (0.0, 30.0, 47.0, 80.0):
        la, lo = np.radians(lat), np.radians(7.0)
        r = np.asarray(geodetic_to_ecef(la, lo, 0.0))
        f_ned = R_ned_from_ecef(la, lo) @ specific_force_ecef_m_s2(r, np.zeros(3), np.zeros(3))
        # J2 only: Somigliana's normal gravity within 1e-4 m/s^2 (the higher zonal terms of the normal field
        # are ~1e-5 relative), and the direction within 0.05 deg of the ellipsoid normal (J4 and beyond)
        assert abs(np.linalg.norm(f_ned) - _somigliana(la)) < 1e-4 * 9.8
        assert np.degrees(np.arccos(-f_ned[2] / np.linalg.norm(f_ned))) < 0.05


def test_coriolis_term_of_an_eastward_ground_vehicle():
    la, lo = 0.0, 0.0
    r = np.asarray(geodetic_to_ecef(la, lo, 0.0))
    v = R_ned_from_ecef(la, lo).T @ np.array([0.0, 100.0, 0.0])       # 100 m/s east on the equator
    f0 = specific_force_ecef_m_s2(r, np.zeros(3), np.zeros(3))
    f1 = specific_force_ecef_m_s2(r, v, np.zeros(3))
    assert np.allclose(f1 - f0, 2 * np.cross(OMEGA_ECEF_RAD_S, v), atol=1e-15)
    assert abs(np.linalg.norm(f1 - f0) - 2 * 7.2921151467e-5 * 100) < 1e-12      # 0.0146 m/s^2


def test_differentiating_filter_noise_gain_and_bias():
    rng = np.random.default_rng(0)
    t = np.arange(0, 2000, 1.0)
    v = np.stack([10 * np.sin(0.02 * t), 5 * np.cos(0.01 * t), 0 * t], 1)
    a_true = np.stack([0.2 * np.cos(0.02 * t), -0.05 * np.sin(0.01 * t), 0 * t], 1)
    noise = rng.normal(0, 0.005, v.shape)
    f = filter_series(t, v + noise, 0.1, derivative=True)
    ok = ~f.edge
    err = f.values[ok] - a_true[ok]
    # the predicted white-noise gain within 10% of the measured scatter (2000 samples, correlated by the filter)
    assert np.allclose(err.std(0), f.noise_gain * 0.005, rtol=0.10)
    # a 0.1 Hz bandwidth passes a 0.003 Hz signal: away from the edges its own error is the central
    # difference's a w^2 dt^2 / 6 ~ 1.3e-5 m/s^2, so 1e-4
    assert np.abs(filter_series(t, v, 0.1, True).values[ok] - a_true[ok]).max() < 1e-4
    # a gap splits the series; a piece shorter than 16 samples gets no derivative
    tg = np.concatenate([t[:100], t[110:115]])
    fg = filter_series(tg, v[:105], 0.1, True)
    assert np.isnan(fg.values[100:]).all() and np.isfinite(fg.values[50]).all()


def test_igrf14_in_ecef_matches_ppigrf_geodetic_and_refuses_other_dates():
    ppigrf_mod = require_module("ppigrf", "IGRF-14 geomagnetic model")
    from gnssatt.single_antenna.geomagnetic import field_ecef_nT

    date = dt.datetime(2025, 6, 1)
    for lat, lon, h in ((46.99, 6.94, 400.0), (-30.0, 150.0, 10000.0), (80.0, -60.0, 600e3)):
        la, lo = np.radians(lat), np.radians(lon)
        b_ned = R_ned_from_ecef(la, lo) @ field_ecef_nT(np.asarray(geodetic_to_ecef(la, lo, h)), date)
        be, bn, bu = (x.ravel()[0] for x in ppigrf_mod.igrf(lon, lat, h / 1e3, date))
        # two paths through the same coefficients (ECEF here, geodetic conversion there): 0.1 nT
        assert np.allclose(b_ned, [bn, be, -bu], atol=0.1)
    # Neuchatel (seed 001's static site): a total field of 47-49 uT (IGRF-14, 2025)
    b = field_ecef_nT(np.asarray(geodetic_to_ecef(np.radians(46.99), np.radians(6.94), 400.0)), date)
    assert 47000 < np.linalg.norm(b) < 49000
    with pytest.raises(ValueError, match="IGRF-14 covers"):
        field_ecef_nT(np.zeros(3) + 7e6, dt.datetime(2031, 1, 1))
