"""SP3 interpolation accuracy: a synthetic Keplerian orbit (analytic truth) and leave-one-out on the real CODE
final orbits; NaN rules (outside span, bad values, time gaps); velocity from the interpolant."""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from tests.conftest import real_set
from gnssatt.gnss.io.sp3 import Sp3Data, read_sp3
from gnssatt.gnss.orbits.sp3_interp import interpolate_sp3, interpolate_sp3_velocity, lagrange_basis
from gnssatt.gnss.time import GpsTime

GM_M3_S2 = 3.986005e14          # IS-GPS-200 WGS 84 value
OMEGA_E_RAD_S = 7.2921151467e-5  # IS-GPS-200


def kepler_ecef(t_s, a_m=26_560e3, e=0.01, i_rad=0.96, raan_rad=0.5, argp_rad=1.0, m0_rad=0.3):
    """(position_ecef_m (n, 3), velocity_ecef_m_s (n, 3)) of a two-body orbit, Earth rotating at OMEGA_E."""
    t = np.asarray(t_s, dtype=float)
    n_rad_s = np.sqrt(GM_M3_S2 / a_m**3)
    m = m0_rad + n_rad_s * t
    ecc = m.copy()
    for _ in range(30):  # Newton on Kepler's equation
        ecc -= (ecc - e * np.sin(ecc) - m) / (1 - e * np.cos(ecc))
    cos_e, sin_e = np.cos(ecc), np.sin(ecc)
    x_p = a_m * (cos_e - e)
    y_p = a_m * np.sqrt(1 - e**2) * sin_e
    edot = n_rad_s / (1 - e * cos_e)
    vx_p = -a_m * sin_e * edot
    vy_p = a_m * np.sqrt(1 - e**2) * cos_e * edot

    def rot(ang, axis):
        c, s = np.cos(ang), np.sin(ang)
        if axis == 3:
            return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])
        return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])
    q = rot(raan_rad, 3) @ rot(i_rad, 1) @ rot(argp_rad, 3)
    r_eci = np.stack([x_p, y_p, np.zeros_like(x_p)], -1) @ q.T
    v_eci = np.stack([vx_p, vy_p, np.zeros_like(x_p)], -1) @ q.T
    th = OMEGA_E_RAD_S * t
    c, s = np.cos(th), np.sin(th)
    r = np.stack([c * r_eci[:, 0] + s * r_eci[:, 1], -s * r_eci[:, 0] + c * r_eci[:, 1], r_eci[:, 2]], -1)
    v_rot = np.stack([c * v_eci[:, 0] + s * v_eci[:, 1], -s * v_eci[:, 0] + c * v_eci[:, 1], v_eci[:, 2]], -1)
    v = v_rot - np.cross([0.0, 0.0, OMEGA_E_RAD_S], r)
    return r, v


def synthetic_sp3(interval_s=900.0, n_ep=97, clock_s=None):
    t0 = GpsTime.from_calendar(2024, 6, 24)
    ts = np.arange(n_ep) * interval_s
    r, _ = kepler_ecef(ts)
    clk = clock_s if clock_s is not None else (1e-4 + 1e-11 * ts)
    return Sp3Data(name="syn", version="d", pos_vel_flag="P", time=t0 + ts, sats=["G01"],
                   position_ecef_m=r[:, None, :], clock_s=np.asarray(clk)[:, None], velocity_ecef_m_s=None,
                   clock_rate_s_s=None, data_used="ORBIT", coordinate_system="IGS20", orbit_type="FIT",
                   agency="TST", time_system="GPS", file_type="G", interval_s=interval_s, n_epochs_header=n_ep)


def test_lagrange_basis_partition_of_unity_and_nodes():
    d = np.array([[-300.0, -100.0, 50.0, 200.0], [0.0, 100.0, 200.0, 300.0]])
    w = lagrange_basis(d)
    np.testing.assert_allclose(w.sum(-1), 1.0, atol=1e-14)
    np.testing.assert_allclose(w[1], [1, 0, 0, 0], atol=1e-15)  # on a node: exactly that node
    np.testing.assert_allclose(lagrange_basis(d, derivative=True).sum(-1), 0.0, atol=1e-16)


def test_synthetic_kepler_orbit_interpolates_below_1_mm_and_velocity():
    """Two-body GPS-like orbit sampled every 15 min; truth is analytic. Midpoints are the worst case."""
    sp3 = synthetic_sp3()
    ts = np.arange(5 * 900.0, 91 * 900.0, 137.0)  # interior times, off the nodes
    t = sp3.time[0] + ts
    pos, clk = interpolate_sp3(sp3, ["G01"], t)
    r_true, v_true = kepler_ecef(ts)
    err_m = np.linalg.norm(pos[:, 0] - r_true, axis=-1)
    assert err_m.max() < 1e-3, f"max position error {err_m.max() * 1e3:.3f} mm"
    vel = interpolate_sp3_velocity(sp3, ["G01"], t)
    verr = np.linalg.norm(vel[:, 0] - v_true, axis=-1)
    assert verr.max() < 1e-5, f"max velocity error {verr.max() * 1e3:.4f} mm/s"  # 0.01 mm/s
    np.testing.assert_allclose(clk[:, 0], 1e-4 + 1e-11 * ts, rtol=0, atol=1e-18)  # linear clock is exact


def test_nan_outside_span_on_bad_values_and_gaps():
    sp3 = synthetic_sp3(n_ep=40)
    t = sp3.time[0] + np.array([-1.0, 0.0, 39 * 900.0, 39 * 900.0 + 1.0])
    pos, clk = interpolate_sp3(sp3, ["G01", "G99"], t)
    assert np.isnan(pos[[0, 3]]).all() and np.isfinite(pos[[1, 2], 0]).all() and np.isnan(pos[:, 1]).all()
    np.testing.assert_allclose(pos[1, 0], sp3.position_ecef_m[0, 0], atol=1e-9)  # on a node
    assert np.isnan(clk[[0, 3]]).all() and np.isfinite(clk[[1, 2], 0]).all()
    bad = dataclasses.replace(sp3, position_ecef_m=sp3.position_ecef_m.copy())
    bad.position_ecef_m[20] = np.nan
    tm = sp3.time[0] + np.array([20.5, 15.5, 24.5, 25.5]) * 900.0  # 10-point windows: 11-20, 20-29, 21-30
    p, _ = interpolate_sp3(bad, ["G01"], tm)
    assert np.isnan(p[:3]).all() and np.isfinite(p[3]).all()  # windows holding epoch 20 are NaN
    keep = np.r_[0:20, 21:40]  # a time gap: epoch 20 missing from the file
    gap = dataclasses.replace(sp3, time=sp3.time[keep], position_ecef_m=sp3.position_ecef_m[keep],
                              clock_s=sp3.clock_s[keep])
    p, _ = interpolate_sp3(gap, ["G01"], tm)
    assert np.isnan(p[:3]).all() and np.isfinite(p[3]).all()


def test_real_cod_leave_one_out():
    """Leave-one-out on CODE final 15-min GPS orbits (cod14193.sp3): drop epoch k, interpolate it from the
    remaining ones (10-point window, so the window spans a 30-min hole) and compare with the dropped value.
    Measured: interior epochs (k = 5..90) RMS 3.9 mm, max 12.5 mm over 2580 satellite-epochs; the first/last
    five epochs (window cannot be centred) max 18 cm."""
    sp3 = read_sp3(real_set("leo_grace_a_2007080") / "cod14193.sp3.gz")
    gps = [s for s in sp3.sats if s.startswith("G")]
    cols = [sp3.sats.index(s) for s in gps]
    interior, edge = [], []
    for k in range(1, 95):
        keep = np.r_[0:k, k + 1:len(sp3.time)]
        red = dataclasses.replace(sp3, time=sp3.time[keep], position_ecef_m=sp3.position_ecef_m[keep],
                                  clock_s=sp3.clock_s[keep])
        pos, _ = interpolate_sp3(red, gps, sp3.time[k], max_step_s=1800.0)
        err = np.linalg.norm(pos[0] - sp3.position_ecef_m[k, cols], axis=-1)
        (interior if 5 <= k <= 90 else edge).append(err[np.isfinite(err)])
    e_in, e_edge = np.concatenate(interior), np.concatenate(edge)
    assert e_in.size > 2500
    assert np.sqrt(np.mean(e_in**2)) < 0.006 and e_in.max() < 0.02   # m
    assert e_edge.max() < 0.3


def test_real_cod_velocity_matches_position_differences():
    sp3 = read_sp3(real_set("leo_grace_a_2007080") / "cod14193.sp3.gz")
    t = sp3.time[40] + np.array([100.0, 101.0])
    p = interpolate_sp3(sp3, ["G05"], t)[0][:, 0]
    v = interpolate_sp3_velocity(sp3, ["G05"], sp3.time[40] + 100.5)[0, 0]
    np.testing.assert_allclose(v, p[1] - p[0], atol=1e-6)  # central difference, m/s
    assert 3000 < np.linalg.norm(v) < 4000  # GPS ECEF speed ~3.1-3.9 km/s
