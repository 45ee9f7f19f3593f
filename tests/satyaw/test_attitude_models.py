"""Yaw attitude models against geometry with known answers (seed 004 sec. 1, 2.4, 2.5; Kouba 2009)."""
import numpy as np
import pytest

from gnssatt.gnss.constants import OMEGA_EARTH_RAD_S
from gnssatt.satyaw.attitude_models import (R_ecef_from_body, model_yaw_deg, nominal_yaw_deg,
                                            nominal_yaw_rate_deg_s, orbit_angles, pseudo_yaw_steering_deg,
                                            wrap_deg)

A_M = 42164e3
MU_RATE = np.sqrt(3.986004418e14 / A_M ** 3)   # rad/s


def _circular(beta_deg, mu_deg, sun_dist_m=1.496e11):
    """Satellite state (ECEF, Earth-fixed velocity) and Sun placed so that beta and mu are as given.
    Orbit plane = ECEF x-y at this instant (normal +z); the Sun's in-plane direction is +x (orbit noon)."""
    b, m = np.radians(beta_deg), np.radians(mu_deg)
    u = np.asarray(m) + np.pi                                  # angle from noon
    r = A_M * np.stack([np.cos(u), np.sin(u), np.zeros_like(u)], -1)
    v_in = A_M * MU_RATE * np.stack([-np.sin(u), np.cos(u), np.zeros_like(u)], -1)
    v_ecef = v_in - np.cross([0, 0, OMEGA_EARTH_RAD_S], r)
    sun = r + sun_dist_m * np.stack([np.cos(b) * np.ones_like(u), np.zeros_like(u), np.sin(b) * np.ones_like(u)], -1)
    return r, v_ecef, sun


@pytest.mark.parametrize("beta,mu", [(10.0, 90.0), (10.0, 0.0), (-25.0, 30.0), (3.0, -120.0), (60.0, 175.0)])
def test_nominal_yaw_is_kouba_formula_and_angles_recovered(beta, mu):
    r, v, sun = _circular(np.array([beta]), np.array([mu]))
    ang = orbit_angles(r, v, sun)
    # sun 1 AU away, seen from the satellite: beta shifts by < A/AU = 0.016 deg
    assert ang.beta_deg[0] == pytest.approx(beta, abs=0.02)
    assert wrap_deg(ang.mu_deg[0] - mu) == pytest.approx(0.0, abs=0.02)
    assert ang.mu_rate_deg_s[0] == pytest.approx(np.degrees(MU_RATE), rel=1e-9)
    expect = np.degrees(np.arctan2(-np.tan(np.radians(beta)), np.sin(np.radians(mu))))
    assert wrap_deg(nominal_yaw_deg(r, v, sun)[0] - expect) == pytest.approx(0.0, abs=0.03)


def test_known_yaw_values_and_sun_on_plus_x():
    # beta = 10 at mu = 90 (dusk side): yaw = -beta; at midnight yaw = -90 (Kouba 2009)
    r, v, sun = _circular(np.array([10.0, 10.0]), np.array([90.0, 0.0]))
    yaw = nominal_yaw_deg(r, v, sun)
    np.testing.assert_allclose(yaw, [-10.0, -90.0], atol=0.03)
    R = R_ecef_from_body(orbit_angles(r, v, sun).R_orbital_from_ecef, yaw)
    s = (sun - r) / np.linalg.norm(sun - r, axis=-1, keepdims=True)
    assert np.all(np.einsum("ni,ni->n", R[..., 0], s) > 0)          # +x on the Sun's side (IGS)
    assert np.allclose(np.einsum("ni,ni->n", R[..., 1], s), 0, atol=1e-9)  # Sun in the x-z plane
    np.testing.assert_allclose(R[..., 2], -r / A_M, atol=1e-12)


def test_yaw_rate_formula_against_finite_difference():
    mu = np.linspace(-40, 40, 4001)
    beta = 2.0
    r, v, sun = _circular(np.full_like(mu, beta), mu)
    yaw = np.unwrap(np.radians(nominal_yaw_deg(r, v, sun)))
    t = np.radians(mu) / MU_RATE
    fd = np.degrees(np.gradient(yaw, t))
    an = nominal_yaw_rate_deg_s(beta, mu, np.degrees(MU_RATE))
    np.testing.assert_allclose(fd, an, atol=2e-4 * np.abs(an).max())   # finite-difference error only
    # extreme at midnight: mu_dot / tan(beta)
    assert np.abs(an).max() == pytest.approx(np.degrees(MU_RATE) / np.tan(np.radians(beta)), rel=1e-6)


def test_pseudo_yaw_steering_rate_limit_and_lead_lag():
    beta = 0.1                               # Fig. 2: beta ~ 0.1 deg midnight turn
    t = np.arange(-3 * 3600.0, 3 * 3600.0, 10.0)
    mu = np.degrees(MU_RATE * t)
    r, v, sun = _circular(np.full_like(mu, beta), mu)
    nom = nominal_yaw_deg(r, v, sun)
    rate = nominal_yaw_rate_deg_s(beta, mu, np.degrees(MU_RATE))
    assert np.abs(rate).max() > 2.0          # nominal needs > 2 deg/s (seed 004: ~1.5 deg/s for its orbit)
    psy = pseudo_yaw_steering_deg(t, nom, rate, rate_limit_deg_s=0.055)
    d_rate = np.diff(np.unwrap(np.radians(psy))) / np.diff(t)
    assert np.degrees(np.abs(d_rate)).max() <= 0.055 + 1e-9
    dev = wrap_deg(psy - nom)
    assert np.abs(dev).max() > 70.0          # Fig. 2: departs from nominal by more than 70 deg
    # leads then lags: the deviation changes sign at the turn centre and is antisymmetric about it
    i0 = np.argmin(np.abs(t))
    assert np.sign(dev[i0 - 30]) == -np.sign(dev[i0 + 30])
    np.testing.assert_allclose(dev[i0 - 300:i0], -dev[i0 + 300:i0:-1], atol=0.2)
    # the turn takes ~180 deg / 0.055 deg/s = 55 min: outside +-40 min it equals the nominal
    far = np.abs(t) > 40 * 60
    assert np.abs(dev[far]).max() < 1e-9
    # at large beta the model is the nominal one
    r, v, sun = _circular(np.full_like(mu, 20.0), mu)
    nom20 = nominal_yaw_deg(r, v, sun)
    np.testing.assert_allclose(model_yaw_deg("qzss-pseudo-yaw-steering", t, nom20), nom20, atol=1e-9)
    np.testing.assert_allclose(model_yaw_deg("orbit-normal", t, nom20), 180.0)
    with pytest.raises(ValueError, match="unknown attitude model"):
        model_yaw_deg("spin", t, nom20)
