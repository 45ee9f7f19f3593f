"""Attitude from baselines: QUEST/TRIAD answer, formal covariance vs Monte Carlo, Euler-sigma mapping, az/el."""
from __future__ import annotations

import numpy as np

from worker.attitude.solution import attitude_from_baselines, baseline_az_el, euler_and_sigma
from worker.gnss import rotations as rot

BODY = np.array([[1.04653, -0.07191, 0.0], [0.0, 1.13969, 0.0]])   # CASSIOPE-like (CONVENTIONS.md)


def _truth(rng):
    q = rot.quat_normalize(rng.normal(size=4))
    return rot.quat_to_dcm(q)


def test_quest_and_triad_recover_the_attitude():
    rng = np.random.default_rng(3)
    R = _truth(rng)
    b_ecef = (BODY @ R)[None]                       # rows: R^T b_body
    for method in ("quest", "triad"):
        q, P = attitude_from_baselines(b_ecef, np.zeros((1, 6, 6)), BODY, method)
        assert rot.attitude_error_deg(q[0], rot.dcm_to_quat(R)) < 1e-9
        assert np.all(np.abs(P) < 1e-20)


def test_formal_covariance_matches_monte_carlo():
    """The propagated 3x3 covariance of the body-frame rotation error agrees with 4000 noisy QUEST runs (10 %)."""
    rng = np.random.default_rng(4)
    R = _truth(rng)
    n = 4000
    A = rng.normal(size=(6, 6)) * 0.002
    C = A @ A.T + np.diag([4e-6, 4e-6, 2.5e-5, 4e-6, 4e-6, 2.5e-5])   # mm-level, correlated baselines
    L = np.linalg.cholesky(C)
    e = (L @ rng.normal(size=(6, n))).T.reshape(n, 2, 3)
    b = (BODY @ R)[None] + e
    q, P = attitude_from_baselines(b, np.broadcast_to(C, (n, 6, 6)), BODY)
    # dtheta from R_est = (I - [dtheta x]) R_true
    D = rot.quat_to_dcm(q) @ R.T
    dth = np.stack([D[:, 1, 2], D[:, 2, 0], D[:, 0, 1]], 1)
    emp = np.cov(dth.T)
    assert np.allclose(np.sqrt(np.diag(emp)), np.sqrt(np.diag(P[0])), rtol=0.1)


def test_euler_sigma_mapping_matches_numeric_jacobian():
    rng = np.random.default_rng(5)
    ypr = np.array([40.0, 25.0, -60.0])
    R = rot.euler321_to_dcm(*ypr)
    A = rng.normal(size=(3, 3)) * 1e-3
    P = A @ A.T
    _, _, _, sy, sp, sr = euler_and_sigma(R[None], P[None])
    # numeric: dtheta -> Euler
    J = np.zeros((3, 3))
    eps = 1e-7
    for i in range(3):
        d = np.zeros(3)
        d[i] = eps
        Rp = (np.eye(3) - np.array([[0, -d[2], d[1]], [d[2], 0, -d[0]], [-d[1], d[0], 0]])) @ R
        J[:, i] = (np.array(rot.dcm_to_euler321(Rp)) - ypr) / np.degrees(eps)
    Pe = J @ P @ J.T
    assert np.allclose([sy[0], sp[0], sr[0]], np.degrees(np.sqrt(np.diag(Pe))), rtol=1e-4)


def test_baseline_azimuth_elevation_and_sigmas():
    from worker.gnss.frames import R_enu_from_ecef

    lat, lon = np.radians(35.13), np.radians(136.98)
    Renu = R_enu_from_ecef(lat, lon)
    enu = np.array([-0.2232, -0.9647, 0.0096])     # the Nagoya baseline of the README
    b = Renu.T @ enu
    P = Renu.T @ np.diag([1e-6, 4e-6, 9e-6]) @ Renu
    L, az, el, sL, saz, sel = baseline_az_el(b[None], P[None], Renu[None])
    assert abs(L[0] - 0.9902) < 1e-4 and abs(az[0] - 193.03) < 0.01 and abs(el[0] - 0.56) < 0.01
    # east error 1 mm, north 2 mm on a north-pointing-ish baseline: sigma_az ~ 1 mm / 0.99 m
    assert 0.04 < saz[0] < 0.15 and abs(sel[0] - np.degrees(3e-3 / 0.9902)) < 0.01
