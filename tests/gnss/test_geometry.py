"""Light time + Sagnac against a brute-force inertial solution; Sagnac sign and size; antenna-frame az/el by hand."""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.optimize import brentq

from tests.conftest import real_set
from gnssatt.gnss import geometry as G
from gnssatt.gnss.constants import C_M_S, OMEGA_EARTH_RAD_S, WGS84_A_M
from gnssatt.gnss.rotations import euler321_to_dcm
from gnssatt.gnss.time import GpsTime

T0 = GpsTime.from_calendar(2021, 9, 22, 6)
RADIUS_M = 26_560e3
N_RAD_S = math.sqrt(3.986005e14 / RADIUS_M ** 3)
INC = math.radians(55.0)


def R3(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])


def inertial_sat(dt_s, phase0):
    """Circular inclined orbit in an inertial frame that coincides with ECEF at T0."""
    u = phase0 + N_RAD_S * dt_s
    return RADIUS_M * np.array([math.cos(u), math.sin(u) * math.cos(INC), math.sin(u) * math.sin(INC)])


def make_source(phases):
    def state(sats, t):
        dts = np.broadcast_to(t - T0, np.shape(sats))
        r = np.array([R3(OMEGA_EARTH_RAD_S * d) @ inertial_sat(d, phases[int(s)]) for s, d in zip(sats, dts)])
        h = 1e-3  # central difference for the velocity (only passed through here)
        rp = np.array([R3(OMEGA_EARTH_RAD_S * (d + h)) @ inertial_sat(d + h, phases[int(s)]) for s, d in zip(sats, dts)])
        rm = np.array([R3(OMEGA_EARTH_RAD_S * (d - h)) @ inertial_sat(d - h, phases[int(s)]) for s, d in zip(sats, dts)])
        return r, (rp - rm) / (2 * h), np.full(len(sats), 1e-4)
    return state


def test_light_time_matches_brute_force_inertial_solution():
    phases = {0: 0.3, 1: 1.1, 2: -0.6, 3: 0.0}
    src = make_source(phases)
    r_rx = np.array([WGS84_A_M, 0.0, 0.0])
    t_rx = T0 + 1000.0
    sats = np.array([0, 1, 2, 3])
    res = G.emission_time_and_position(src, sats, r_rx, t_rx)
    assert res.converged.all()
    th_rx = OMEGA_EARTH_RAD_S * 1000.0
    x_rx = R3(th_rx).T @ r_rx  # receiver in the inertial frame at reception
    for k, s in enumerate(sats):
        f = lambda tau: np.linalg.norm(inertial_sat(1000.0 - tau, phases[int(s)]) - x_rx) - C_M_S * tau  # noqa: E731
        tau = brentq(f, 0.0, 0.2, xtol=1e-16, rtol=1e-15)
        assert abs(res.tau_s[k] - tau) < 1e-12
        expected_r = R3(th_rx) @ inertial_sat(1000.0 - tau, phases[int(s)])
        assert np.linalg.norm(res.r_sat_ecef_m[k] - expected_r) < 1e-3
        assert abs(res.range_m[k] - C_M_S * tau) < 1e-3
    assert np.all(np.abs((t_rx - res.t_tx) - res.tau_s) < 1e-9)
    np.testing.assert_allclose(np.linalg.norm(res.los_ecef, axis=1), 1.0, atol=1e-15)
    np.testing.assert_allclose(res.clock_s, 1e-4)


def test_sagnac_sign_and_size_at_the_equator():
    """A satellite fixed in ECEF at 50 deg E over the equator, receiver at 0 deg E: the receiver moves east
    towards the satellite during the ~70 ms flight, so the range is SHORTER than the instantaneous distance by
    omega/c (x_s y_r - y_s x_r) ~ 31.6 m."""
    r_sat = RADIUS_M * np.array([math.cos(math.radians(50)), math.sin(math.radians(50)), 0.0])
    r_rx = np.array([WGS84_A_M, 0.0, 0.0])
    src = lambda sats, t: (np.tile(r_sat, (len(sats), 1)), None)  # noqa: E731
    res = G.emission_time_and_position(src, np.array(["X"]), r_rx, T0)
    no_sagnac = np.linalg.norm(r_sat - r_rx)
    corr = res.range_m[0] - no_sagnac
    formula = OMEGA_EARTH_RAD_S / C_M_S * (r_sat[0] * r_rx[1] - r_sat[1] * r_rx[0])
    assert -40.0 < corr < -20.0
    assert abs(corr - formula) < 0.01
    # a satellite to the west gets the opposite sign
    r_w = r_sat * np.array([1, -1, 1])
    res_w = G.emission_time_and_position(lambda s, t: (np.tile(r_w, (len(s), 1)), None), ["X"], r_rx, T0)
    assert res_w.range_m[0] - no_sagnac == pytest.approx(-corr, abs=0.01)
    assert np.isnan(res.v_sat_ecef_m_s).all() and np.isnan(res.clock_s).all()


def test_sagnac_rotate_is_frame_rotation():
    v = G.sagnac_rotate(np.array([1.0, 0, 0]), np.pi / 2 / OMEGA_EARTH_RAD_S)
    np.testing.assert_allclose(v, [0, -1, 0], atol=1e-12)  # points appear rotated west


def test_broadcast_ranges_explain_real_pseudoranges():
    """GEONET 0759, 2005-04-02: C1 - (rho - c dt_sv) is one receiver clock for all satellites up to the
    atmosphere above 15 deg elevation (measured: scatter 2.8 m, max 5.4 m). Dropping the Sagnac rotation
    (omega = 0) gives 18 m scatter and 34 m max, so the bounds below (10 m, 5 m) catch it."""
    from gnssatt.gnss.io.rinex_nav import read_rinex_nav
    from gnssatt.gnss.io.rinex_obs import read_rinex_obs
    from gnssatt.gnss.orbits.broadcast import BroadcastOrbit

    d = real_set("geonet_0759_3040_3km_2005")
    obs = read_rinex_obs(d / "07590920.05o")
    orbit = BroadcastOrbit(read_rinex_nav(d / "07590920.05n").kepler["G"])
    r_rx = obs.header.approx_position_ecef_m
    ic = obs.codes.index("C1")
    for k in (0, 60):
        p = obs.values[k, :, ic]
        ok = np.isfinite(p) & np.array([s.startswith("G") for s in obs.sats])
        sats = np.array(obs.sats)[ok]
        t_rx = obs.time[k]  # receiver clock offset (< 1 ms) ignored: common to all satellites to ~1 m/ms
        res = G.emission_time_and_position(orbit, sats, r_rx, t_rx, tau0_s=p[ok] / C_M_S)
        el, _ = G.elevation_azimuth_local(r_rx, res.r_sat_ecef_m)
        resid = p[ok] - (res.range_m - C_M_S * res.clock_s)
        keep = np.degrees(el) > 15
        assert keep.sum() >= 5
        r = resid[keep] - np.median(resid[keep])
        assert np.max(np.abs(r)) < 10.0 and np.std(r) < 5.0


def test_elevation_azimuth_local_order():
    r0 = np.array([WGS84_A_M, 0.0, 0.0])
    el, az = G.elevation_azimuth_local(r0, np.array([WGS84_A_M + 1000.0, 1000.0, 0.0]))
    assert math.degrees(el) == pytest.approx(45.0) and math.degrees(az) == pytest.approx(90.0)


@pytest.mark.parametrize("los_body, az_deg, el_deg", [
    ([0, 0, -1], None, 90.0),   # along the boresight
    ([0, 0, 1], None, -90.0),   # behind
    ([1, 0, 0], 0.0, 0.0),      # body x = antenna x
    ([0, -1, 0], 90.0, 0.0),    # antenna y = z_ant x x_ant = (-z) x x = -y_body
    ([0, 1, 0], 270.0, 0.0),
    ([1, 0, -1], 0.0, 45.0),
])
def test_antenna_frame_boresight_minus_z(los_body, az_deg, el_deg):
    """The CONVENTIONS.md example platform: boresight [0, 0, -1], attitude identity (body = ECEF)."""
    az, el = G.azimuth_elevation_antenna(np.array(los_body, float), np.eye(3), [0, 0, -1.0])
    assert math.degrees(el) == pytest.approx(el_deg, abs=1e-12)
    if az_deg is not None:
        assert math.degrees(az) == pytest.approx(az_deg, abs=1e-12)


def test_antenna_frame_boresight_along_body_x_uses_body_y():
    Ra = G.R_antenna_from_body([1.0, 0, 0])
    np.testing.assert_allclose(Ra, [[0, 1, 0], [0, 0, 1], [1, 0, 0]], atol=1e-15)  # x=y_b, y=z_b, z=x_b
    az, el = G.azimuth_elevation_antenna(np.array([0, 0, 1.0]), np.eye(3), [1.0, 0, 0])
    assert math.degrees(az) == pytest.approx(90.0) and math.degrees(el) == pytest.approx(0.0, abs=1e-12)
    # right-handed, orthonormal for arbitrary boresights (vectorised)
    rng = np.random.default_rng(2)
    b = rng.normal(size=(50, 3))
    Ra = G.R_antenna_from_body(b)
    np.testing.assert_allclose(np.linalg.det(Ra), 1.0, atol=1e-12)
    np.testing.assert_allclose(Ra[:, 2], b / np.linalg.norm(b, axis=1, keepdims=True), atol=1e-15)
    # antenna x lies in the plane spanned by body x and the boresight (the projection of body x)
    np.testing.assert_allclose(np.einsum("ni,ni->n", Ra[:, 0], np.cross(b, [1.0, 0, 0])), 0.0, atol=1e-12)


def test_antenna_az_el_with_attitude():
    """Body yawed +90 deg from ECEF (R_body_from_ecef = Rz(90)): ECEF +y is body +x, so a satellite along ECEF +y
    is at antenna azimuth 0, elevation 0 for the boresight body -z antenna."""
    R = euler321_to_dcm(90.0, 0.0, 0.0)
    az, el = G.azimuth_elevation_antenna(np.array([0, 1.0, 0]), R, [0, 0, -1.0])
    assert math.degrees(az) == pytest.approx(0.0, abs=1e-9) and math.degrees(el) == pytest.approx(0.0, abs=1e-9)
    az, el = G.azimuth_elevation_antenna(np.array([[1.0, 0, 0], [0, 0, -1.0]]), np.stack([R, R]), [0, 0, -1.0])
    # ECEF +x is body -y -> antenna +y -> azimuth 90; ECEF -z is body -z -> boresight
    assert math.degrees(az[0]) == pytest.approx(90.0) and math.degrees(el[1]) == pytest.approx(90.0)
