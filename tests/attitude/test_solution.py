"""Attitude from baselines: QUEST/TRIAD answer, formal covariance vs Monte Carlo, Euler-sigma mapping, az/el."""
from __future__ import annotations

import numpy as np

from gnssatt.attitude.solution import (ML_BODY_SIGMA_M, attitude_from_baselines, attitude_ml, baseline_az_el,
                                     euler_and_sigma)
from gnssatt.gnss import rotations as rot

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


def _dtheta(q, R):
    """Body-frame rotation errors (n, 3) of q against R_true: R_est = (I - [dtheta x]) R_true."""
    D = rot.quat_to_dcm(q) @ R.T
    return np.stack([D[:, 1, 2], D[:, 2, 0], D[:, 0, 1]], 1)


def test_ml_attitude_converges_from_a_wrong_start_and_marks_bad_rows():
    rng = np.random.default_rng(5)
    R = _truth(rng)
    b = np.stack([BODY @ R, BODY @ R])
    b[1, 0, 0] = np.nan
    q0 = rot.quat_multiply(rot.quat_from_rotvec(np.radians([4.0, -3.0, 5.0])), rot.dcm_to_quat(R))
    C = np.broadcast_to(np.eye(6) * 1e-6, (2, 6, 6))
    q, P = attitude_ml(b, C, BODY, np.stack([q0, q0]))
    assert rot.attitude_error_deg(q[0], rot.dcm_to_quat(R)) < 1e-8
    assert np.isnan(q[1]).all() and np.isnan(P[1]).all() and np.isfinite(P[0]).all()


def test_ml_with_isotropic_covariances_is_wahba_with_length_over_variance_weights():
    """sum |b_j - R^T B_j|^2 / s_j^2 = const - 2 sum |b_j| |B_j| / s_j^2 (unit b_j . R^T unit B_j): QUEST's solution
    with those weights (independent implementation: rotations.quest); s_j^2 includes the body baselines' own
    variance ML_BODY_SIGMA_M^2."""
    rng = np.random.default_rng(6)
    R = _truth(rng)
    n = 50
    s2 = np.array([2e-6, 9e-6])
    b = (BODY @ R)[None] + rng.normal(size=(n, 2, 3)) * np.sqrt(s2)[None, :, None]
    C = np.zeros((n, 6, 6))
    C[:, 0:3, 0:3] = np.eye(3) * s2[0]
    C[:, 3:6, 3:6] = np.eye(3) * s2[1]
    q, _ = attitude_from_baselines(b, C, BODY, "ml")
    w = np.linalg.norm(b, axis=-1) * np.linalg.norm(BODY, axis=-1)[None] / (s2 + ML_BODY_SIGMA_M ** 2)[None]
    q_w, _ = rot.quest(np.broadcast_to(BODY, b.shape), b, w)
    assert np.max(rot.attitude_error_deg(q, q_w)) < 1e-7


def test_ml_uses_the_covariance_shape_better_than_quest_and_its_covariance_is_honest():
    """Vertical baseline noise 6x the horizontal (zenith antennas, VDOP > HDOP), correlated baselines (common
    master antenna): the ML attitude's empirical covariance matches its formal one (10 %); its yaw (from the
    horizontal components, which QUEST mixes with the noisy vertical ones through its scalar weights) is better
    than QUEST's, and its tilts (set by the vertical components alone in this geometry) are no worse."""
    rng = np.random.default_rng(7)
    R = np.eye(3)                                     # body = local level: z is the vertical of the errors
    n = 4000
    blk = np.diag([1.0, 1.0, 36.0]) * 4e-6
    C = np.block([[blk, 0.5 * blk], [0.5 * blk, blk]])
    e = (np.linalg.cholesky(C) @ rng.normal(size=(6, n))).T.reshape(n, 2, 3)
    b = (BODY @ R)[None] + e
    Cn = np.broadcast_to(C, (n, 6, 6))
    q_ml, P_ml = attitude_from_baselines(b, Cn, BODY, "ml", body_sigma_m=0.0)     # exact body baselines here
    q_q, P_q = attitude_from_baselines(b, Cn, BODY, "quest")
    emp_ml, emp_q = np.cov(_dtheta(q_ml, R).T), np.cov(_dtheta(q_q, R).T)
    assert np.allclose(np.sqrt(np.diag(emp_ml)), np.sqrt(np.diag(P_ml[0])), rtol=0.1)
    assert np.allclose(np.sqrt(np.diag(emp_q)), np.sqrt(np.diag(P_q[0])), rtol=0.1)
    assert emp_ml[2, 2] < 0.85 * emp_q[2, 2], (np.diag(emp_ml), np.diag(emp_q))
    assert np.all(np.diag(emp_ml)[:2] <= 1.02 * np.diag(emp_q)[:2]), (np.diag(emp_ml), np.diag(emp_q))


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
    from gnssatt.gnss.frames import R_enu_from_ecef

    lat, lon = np.radians(35.13), np.radians(136.98)
    Renu = R_enu_from_ecef(lat, lon)
    enu = np.array([-0.2232, -0.9647, 0.0096])     # the Nagoya baseline of the README
    b = Renu.T @ enu
    P = Renu.T @ np.diag([1e-6, 4e-6, 9e-6]) @ Renu
    L, az, el, sL, saz, sel = baseline_az_el(b[None], P[None], Renu[None])
    assert abs(L[0] - 0.9902) < 1e-4 and abs(az[0] - 193.03) < 0.01 and abs(el[0] - 0.56) < 0.01
    # east error 1 mm, north 2 mm on a north-pointing-ish baseline: sigma_az ~ 1 mm / 0.99 m
    assert 0.04 < saz[0] < 0.15 and abs(sel[0] - np.degrees(3e-3 / 0.9902)) < 0.01
