"""Quaternion / DCM / Euler conventions of CONVENTIONS.md, worked by hand and as properties; QUEST and TRIAD."""
from __future__ import annotations

import numpy as np
import pytest
from hypothesis import assume, given, settings, strategies as st
from hypothesis.extra.numpy import arrays

from gnssatt.gnss import rotations as rot

finite = st.floats(-1.0, 1.0, allow_nan=False)
quats = arrays(np.float64, (4,), elements=finite).filter(lambda q: np.linalg.norm(q) > 0.1)


def shuster_R(q):
    """R(q) written straight from CONVENTIONS.md: (w^2 - |u|^2) I + 2 u u^T - 2 w [u x]."""
    q = np.asarray(q, float) / np.linalg.norm(q)
    w, u = q[0], q[1:]
    ux = np.array([[0, -u[2], u[1]], [u[2], 0, -u[0]], [-u[1], u[0], 0]])
    return (w * w - u @ u) * np.eye(3) + 2 * np.outer(u, u) - 2 * w * ux


# --- hand-worked ---------------------------------------------------------------------------------------

def test_quat_to_dcm_is_the_convention_formula_and_frame_rotation_about_z():
    a = np.radians(30.0)
    q = np.array([np.cos(a / 2), 0, 0, np.sin(a / 2)])
    c, s = np.cos(a), np.sin(a)
    expected = np.array([[c, s, 0], [-s, c, 0], [0, 0, 1]])  # passive: the frame turns +30 deg about z
    np.testing.assert_allclose(rot.quat_to_dcm(q), expected, atol=1e-15)
    np.testing.assert_allclose(shuster_R(q), expected, atol=1e-15)
    np.testing.assert_allclose(rot.quat_from_axis_angle([0, 0, 1.0], a), q, atol=1e-15)
    # a vector along ref x seen from a frame turned +30 deg about z has a negative y component
    v = rot.rotate(q, [1.0, 0, 0])
    np.testing.assert_allclose(v, [c, -s, 0], atol=1e-15)


def test_euler_hand_worked_yaw_pitch_roll():
    # yaw +90: body x points where ref y was; ref x (north in NED) appears at body -y (to the left)
    R = rot.euler321_to_dcm(90.0, 0.0, 0.0)
    np.testing.assert_allclose(R, [[0, 1, 0], [-1, 0, 0], [0, 0, 1]], atol=1e-15)
    np.testing.assert_allclose(R @ [1, 0, 0], [0, -1, 0], atol=1e-15)
    # pitch +90 (nose up): ref z (down) appears at body -x
    R = rot.euler321_to_dcm(0.0, 90.0, 0.0)
    np.testing.assert_allclose(R, [[0, 0, -1], [0, 1, 0], [1, 0, 0]], atol=1e-15)
    np.testing.assert_allclose(R @ [0, 0, 1], [-1, 0, 0], atol=1e-15)
    # roll +90 (right wing down): ref z (down) appears at body +y
    R = rot.euler321_to_dcm(0.0, 0.0, 90.0)
    np.testing.assert_allclose(R, [[1, 0, 0], [0, 0, 1], [0, -1, 0]], atol=1e-15)
    np.testing.assert_allclose(R @ [0, 0, 1], [0, 1, 0], atol=1e-15)
    # order matters: Rx(roll) Ry(pitch) Rz(yaw) for yaw 90, pitch 30 (written out by hand)
    c, s = np.cos(np.radians(30)), np.sin(np.radians(30))
    expected = np.array([[c, 0, -s], [0, 1, 0], [s, 0, c]]) @ np.array([[0, 1, 0], [-1, 0, 0], [0, 0, 1]])
    np.testing.assert_allclose(rot.euler321_to_dcm(90.0, 30.0, 0.0), expected, atol=1e-15)
    np.testing.assert_allclose(expected, [[0, c, -s], [-1, 0, 0], [0, s, c]], atol=1e-15)


def test_quat_multiply_composes_like_matrices_hand_case():
    qz = rot.quat_from_axis_angle([0, 0, 1.0], np.pi / 2)
    qx = rot.quat_from_axis_angle([1.0, 0, 0], np.pi / 2)
    np.testing.assert_allclose(rot.quat_to_dcm(rot.quat_multiply(qx, qz)),
                               rot.Rx(np.pi / 2) @ rot.Rz(np.pi / 2), atol=1e-15)
    # and the other order is a different rotation (the test can fail)
    assert np.abs(rot.quat_to_dcm(rot.quat_multiply(qz, qx)) - rot.Rx(np.pi / 2) @ rot.Rz(np.pi / 2)).max() > 0.5


def test_dcm_to_euler_ranges_and_gimbal_lock():
    y, p, r = rot.dcm_to_euler321(rot.euler321_to_dcm(180.0, 0.0, -180.0))
    assert y == pytest.approx(180.0) and r == pytest.approx(180.0) and p == pytest.approx(0.0, abs=1e-12)
    y, p, r = rot.dcm_to_euler321(rot.euler321_to_dcm(40.0, 90.0, 10.0))
    assert p == pytest.approx(90.0) and r == 0.0 and y == pytest.approx(30.0)  # only yaw - roll defined
    np.testing.assert_allclose(rot.euler321_to_dcm(y, p, r), rot.euler321_to_dcm(40.0, 90.0, 10.0), atol=1e-12)
    y, p, r = rot.dcm_to_euler321(rot.euler321_to_dcm(40.0, -90.0, 10.0))
    assert p == pytest.approx(-90.0) and r == 0.0 and y == pytest.approx(50.0)  # yaw + roll
    np.testing.assert_allclose(rot.euler321_to_dcm(y, p, r), rot.euler321_to_dcm(40.0, -90.0, 10.0), atol=1e-12)


def test_attitude_error_hand_cases():
    q = rot.euler321_to_dcm(10.0, 0.0, 0.0)
    q1 = rot.dcm_to_quat(q)
    assert rot.attitude_error_deg(q1, [1.0, 0, 0, 0]) == pytest.approx(10.0, abs=1e-12)
    tiny = rot.quat_from_rotvec([1e-9, 0, 0])
    assert rot.attitude_error_deg(tiny, [1.0, 0, 0, 0]) == pytest.approx(np.degrees(1e-9), rel=1e-6)
    assert rot.attitude_error_deg(-q1, q1) == pytest.approx(0.0, abs=1e-12)  # sign does not matter
    assert rot.attitude_error_deg(rot.quat_from_axis_angle([0, 1.0, 0], np.pi), [1.0, 0, 0, 0]) == pytest.approx(180)


# --- properties -------------------------------------------------------------------------------------

@settings(max_examples=300, deadline=None)
@given(q=quats)
def test_q_R_q_round_trip_orthonormal_positive_w(q):
    R = rot.quat_to_dcm(q)
    np.testing.assert_allclose(R, shuster_R(q), atol=1e-14)
    np.testing.assert_allclose(R @ R.T, np.eye(3), atol=1e-14)
    assert np.linalg.det(R) == pytest.approx(1.0, abs=1e-14)
    q2 = rot.dcm_to_quat(R)
    assert q2[0] >= 0.0 and np.linalg.norm(q2) == pytest.approx(1.0, abs=1e-15)
    qn = rot.quat_normalize(q)
    np.testing.assert_allclose(q2 if q2 @ qn >= 0 else -q2, qn, atol=1e-13)  # w = 0 is sign-ambiguous
    if qn[0] > 1e-9:
        np.testing.assert_allclose(q2, qn, atol=1e-13)


@settings(max_examples=300, deadline=None)
@given(p=quats, q=quats)
def test_multiply_composes_and_conjugate_inverts(p, q):
    np.testing.assert_allclose(rot.quat_to_dcm(rot.quat_multiply(p, q)),
                               rot.quat_to_dcm(p) @ rot.quat_to_dcm(q), atol=1e-13)
    np.testing.assert_allclose(rot.quat_to_dcm(rot.quat_conjugate(rot.quat_normalize(q))),
                               rot.quat_to_dcm(q).T, atol=1e-14)
    assert rot.quat_multiply(p, q)[0] >= 0


@settings(max_examples=300, deadline=None)
@given(y=st.floats(-179.999, 180.0), p=st.floats(-89.0, 89.0), r=st.floats(-179.999, 180.0))
def test_euler_round_trip_away_from_gimbal_lock(y, p, r):
    R = rot.euler321_to_dcm(y, p, r)
    y2, p2, r2 = rot.dcm_to_euler321(R)
    assert -180.0 < y2 <= 180.0 and -90.0 <= p2 <= 90.0 and -180.0 < r2 <= 180.0
    assert abs((y2 - y + 180.0) % 360.0 - 180.0) < 1e-8
    assert abs(p2 - p) < 1e-8
    assert abs((r2 - r + 180.0) % 360.0 - 180.0) < 1e-8


@settings(max_examples=100, deadline=None)
@given(v=arrays(np.float64, (3,), elements=st.floats(-3.0, 3.0)))
def test_rotvec_round_trip(v):
    assume(np.linalg.norm(v) < np.pi - 1e-6)
    np.testing.assert_allclose(rot.quat_to_rotvec(rot.quat_from_rotvec(v)), v, atol=1e-12)


def test_vectorised_shapes():
    rng = np.random.default_rng(0)
    q = rot.quat_normalize(rng.normal(size=(5, 7, 4)))
    R = rot.quat_to_dcm(q)
    assert R.shape == (5, 7, 3, 3)
    assert rot.dcm_to_quat(R).shape == (5, 7, 4)
    y, p, r = rot.dcm_to_euler321(R)
    assert y.shape == (5, 7)
    assert rot.euler321_to_dcm(y, p, r).shape == (5, 7, 3, 3)
    assert rot.attitude_error_deg(q, q).shape == (5, 7)
    np.testing.assert_allclose(rot.attitude_error_deg(q, q), 0.0, atol=1e-6)


def test_dcm_to_quat_near_180_deg_all_axes():
    for axis in ([1.0, 0, 0], [0, 1.0, 0], [0, 0, 1.0], [1.0, 1.0, 1.0], [1.0, -2.0, 0.5]):
        for ang in (np.pi, np.pi - 1e-9, np.pi - 1e-4):
            q = rot.quat_from_axis_angle(axis, ang)
            q2 = rot.dcm_to_quat(rot.quat_to_dcm(q))
            assert rot.attitude_error_deg(q2, q) < 1e-10


# --- Wahba solvers ------------------------------------------------------------------------------------

def test_quest_recovers_known_rotation_from_noisy_vectors_and_covariance_is_calibrated():
    rng = np.random.default_rng(42)
    n_epochs, n_vec = 400, 6
    sigma = 1e-3  # rad per vector
    q_true = rot.quat_normalize(rng.normal(size=(n_epochs, 4)))
    r = rng.normal(size=(n_epochs, n_vec, 3))
    r /= np.linalg.norm(r, axis=-1, keepdims=True)
    b_true = rot.rotate(rot.quat_to_dcm(q_true)[:, None], r)
    noise = rng.normal(size=b_true.shape) * sigma
    noise -= np.sum(noise * b_true, -1, keepdims=True) * b_true  # tangent-plane noise
    b = b_true + noise
    q, P = rot.quest(b, r, np.full((n_epochs, n_vec), 1 / sigma ** 2))
    assert q.shape == (n_epochs, 4) and P.shape == (n_epochs, 3, 3) and np.all(q[:, 0] >= 0)
    err = rot.attitude_error_deg(q, q_true)
    assert np.median(err) < np.degrees(3 * sigma) and err.max() < np.degrees(10 * sigma)
    # normalised error: delta_theta^T P^-1 delta_theta ~ chi2(3), mean 3
    d = rot.quat_multiply(q, rot.quat_conjugate(q_true), canonical=True)
    dtheta = rot.quat_to_rotvec(d)
    nees = np.einsum("ni,nij,nj->n", dtheta, np.linalg.inv(P), dtheta)
    assert 2.5 < nees.mean() < 3.5
    # noiseless: exact
    q0, _ = rot.quest(b_true, r)
    assert rot.attitude_error_deg(q0, q_true).max() < 1e-9


def test_quest_handles_180_deg_ignored_vectors_and_degenerate_geometry():
    q_true = rot.quat_from_axis_angle([0.3, -0.4, 0.2], np.pi)
    r = np.array([[1.0, 0, 0], [0, 1.0, 0], [0, 0, 1.0], [np.nan, 0, 0]])
    b = rot.rotate(q_true, r)
    q, P = rot.quest(b, r, [1.0, 1.0, 1.0, 1.0])
    assert rot.attitude_error_deg(q, q_true) < 1e-9 and np.isfinite(P).all()
    q, P = rot.quest(b[:3], r[:3], [1.0, 1.0, 0.0])  # weight 0 drops the third: still 2 vectors
    assert rot.attitude_error_deg(q, q_true) < 1e-9
    q, P = rot.quest(b[:1], r[:1])  # one vector: unobservable about it
    assert np.isnan(q).all() and np.isnan(P).all()


def test_triad():
    q_true = rot.dcm_to_quat(rot.euler321_to_dcm(33.0, -12.0, 140.0))
    r1, r2 = np.array([0.2, 0.9, -0.1]), np.array([-0.5, 0.1, 0.8])
    q = rot.triad(rot.rotate(q_true, r1), rot.rotate(q_true, r2), r1, r2)
    assert rot.attitude_error_deg(q, q_true) < 1e-12
    # v1 is matched exactly even when v2 is noisy
    b2 = rot.rotate(q_true, r2) + np.array([0.01, -0.02, 0.0])
    q = rot.triad(rot.rotate(q_true, r1), b2, r1, r2)
    np.testing.assert_allclose(rot.rotate(q, r1 / np.linalg.norm(r1)),
                               rot.rotate(q_true, r1 / np.linalg.norm(r1)), atol=1e-14)
    assert np.isnan(rot.triad(r1, 2 * r1, r1, 2 * r1)).all()


def test_skew_is_the_cross_product_for_one_vector_and_for_stacks():
    """skew(a) @ b == a x b (to rounding of two products of O(1) numbers) and skew(a) is antisymmetric, for one
    vector and for a (4, 5, 3) stack; the one table every module's [v x] comes from."""
    rng = np.random.default_rng(7)
    a, b = rng.normal(size=(4, 5, 3)), rng.normal(size=(4, 5, 3))
    S = rot.skew(a)
    assert S.shape == (4, 5, 3, 3)
    np.testing.assert_allclose(np.einsum("...ij,...j->...i", S, b), np.cross(a, b), atol=1e-14)
    np.testing.assert_array_equal(S, -np.swapaxes(S, -1, -2))
    np.testing.assert_allclose(rot.skew([1.0, 2.0, 3.0]) @ [4.0, 5.0, 6.0], np.cross([1, 2, 3], [4, 5, 6]),
                               atol=1e-14)
