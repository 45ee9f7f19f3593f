"""Wahba by SVD against known rotations, the q-method, a Monte Carlo of the Markley covariance and the flags."""
from __future__ import annotations

import numpy as np

from gnssatt.gnss.rotations import attitude_error_deg, euler321_to_dcm, quat_to_dcm, quest
from gnssatt.single_antenna.wahba import (FLAG_NEAR_PARALLEL, FLAG_OK, FLAG_TOO_FEW, spanned_angle_deg,
                                          wahba_svd)


def _random_rotations(rng, n):
    q = rng.normal(size=(n, 4))
    q /= np.linalg.norm(q, axis=-1, keepdims=True)
    return q * np.sign(q[:, :1]), quat_to_dcm(q)


def test_exact_vectors_give_the_rotation_and_agree_with_qmethod():
    rng = np.random.default_rng(7)
    q, R = _random_rotations(rng, 200)
    r = rng.normal(size=(200, 3, 3))
    r /= np.linalg.norm(r, axis=-1, keepdims=True)
    b = np.einsum("nij,nkj->nki", R, r)
    sol = wahba_svd(b, r)
    assert (sol.flags == FLAG_OK).all()
    # noise-free vectors: float64 round-off only (1e-9 deg is ~1e-11 rad)
    assert attitude_error_deg(sol.q_body_from_ref, q).max() < 1e-9
    assert sol.qmethod_diff_deg.max() < 1e-9
    assert np.abs(sol.loss).max() < 1e-9


def test_180_degree_rotation_and_euler_case():
    R = euler321_to_dcm(180.0, 0.0, 0.0)
    r = np.array([[1.0, 0.2, 0.1], [0.0, 1.0, 0.5]])
    b = r @ R.T
    sol = wahba_svd(b, r)
    assert np.allclose(sol.R_body_from_ref, R, atol=1e-12)


def test_markley_covariance_matches_monte_carlo():
    rng = np.random.default_rng(11)
    R = euler321_to_dcm(30.0, -10.0, 5.0)
    r = np.array([[1.0, 0.0, 0.0], [0.3, 1.0, 0.2]])
    r /= np.linalg.norm(r, axis=-1, keepdims=True)
    sigma = np.array([1e-3, 3e-3])  # rad
    n = 4000
    b = (r @ R.T)[None] + rng.normal(size=(n, 2, 3)) * sigma[None, :, None]
    sol = wahba_svd(b, r, 1.0 / sigma**2)
    # small-angle body-frame error: R_est R_true^T = I - [dtheta x]
    E = sol.R_body_from_ref @ R.T
    dth = np.stack([E[:, 2, 1] - E[:, 1, 2], E[:, 0, 2] - E[:, 2, 0], E[:, 1, 0] - E[:, 0, 1]], -1) / -2.0
    emp = np.cov(dth.T)
    pred = sol.cov_body_rad2.mean(0)
    # a 3-d noise on a unit vector has 2 effective angular dof of sigma each; 4000 draws: ~5% on a variance
    assert np.allclose(np.sqrt(np.diag(emp)), np.sqrt(np.diag(pred)), rtol=0.06)
    # the q-method's (QUEST) covariance agrees with Markley's to first order in the noise: the two evaluate
    # the information at slightly different vectors, O(sigma) = 0.3% apart here, so 1%
    _, P_quest = quest(b[:5], r, 1.0 / sigma**2)
    assert np.allclose(P_quest, sol.cov_body_rad2[:5], rtol=1e-2, atol=1e-2 * np.abs(P_quest).max())


def test_parallel_and_too_few_vectors_are_flagged_not_solved():
    r = np.array([[1.0, 0.0, 0.0], [1.0, 0.02, 0.0]])     # 1.15 deg apart
    sol = wahba_svd(r, r, min_angle_deg=5.0)
    assert sol.flags == FLAG_NEAR_PARALLEL and np.isnan(sol.q_body_from_ref).all()
    assert abs(sol.min_angle_deg - np.degrees(np.arctan(0.02))) < 1e-9
    one = wahba_svd(r[:1], r[:1])
    assert one.flags == FLAG_TOO_FEW and np.isnan(one.R_body_from_ref).all()
    nan = wahba_svd(np.array([[1.0, 0, 0], [np.nan, 0, 1]]), np.array([[1.0, 0, 0], [0, 0, 1]]))
    assert nan.flags == FLAG_TOO_FEW


def test_spanned_angle_of_two_vectors_is_their_folded_angle():
    for t in (3.0, 45.0, 89.0, 120.0, 178.0):
        v = np.array([[1.0, 0, 0], [np.cos(np.radians(t)), np.sin(np.radians(t)), 0]])
        assert abs(spanned_angle_deg(v, np.array([True, True])) - min(t, 180 - t)) < 1e-9
